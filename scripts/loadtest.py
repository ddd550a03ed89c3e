#!/usr/bin/env python
"""Submission latency under load: C concurrent clients each POST /api/jobs N times
(small recovery specs, distinct seeds) and we report p50 / p99 / max of the request time.

    python scripts/loadtest.py                       # starts its own `gaitmend serve` (SQLite,
                                                     # embedded broker, no worker) in a temp dir
    python scripts/loadtest.py --server http://127.0.0.1:8000 --token gm_...

Only submission is measured: jobs stay queued (no worker), so the search does not compete
for the CPU with the API."""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time

import httpx


def spec(seed: int) -> dict:
    return {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
            "search": {"population": 6, "generations": 3, "seed": seed}, "sim": {"duration_s": 2.0}}


def percentile(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    k = min(len(xs) - 1, max(0, round(q / 100 * (len(xs) - 1))))
    return xs[k]


async def client(c: httpx.AsyncClient, idx: int, n: int, lat: list[float], errors: list[str]):
    for i in range(n):
        t0 = time.perf_counter()
        r = await c.post("/api/jobs", json=spec(idx * 1000 + i))
        lat.append(time.perf_counter() - t0)
        if r.status_code != 201:
            errors.append(f"{r.status_code} {r.text[:200]}")


async def run(base: str, token: str, clients: int, per_client: int) -> dict:
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    # Clients (one connection each) are made and connected before the clock starts: making
    # an httpx client costs tens of ms of CPU here, which would be counted as server latency.
    pool = [httpx.AsyncClient(base_url=base, headers=headers, timeout=60) for _ in range(clients)]
    try:
        await asyncio.gather(*(c.get("/api/health") for c in pool))
        (await pool[0].post("/api/jobs", json=spec(10**6))).raise_for_status()
        lat, errors = [], []
        t0 = time.perf_counter()
        await asyncio.gather(*(client(c, i, per_client, lat, errors) for i, c in enumerate(pool)))
        wall = time.perf_counter() - t0
    finally:
        await asyncio.gather(*(c.aclose() for c in pool))
    return {"clients": clients, "requests": len(lat), "errors": len(errors), "first_error": errors[:1],
            "p50_ms": round(1000 * percentile(lat, 50), 1), "p99_ms": round(1000 * percentile(lat, 99), 1),
            "max_ms": round(1000 * max(lat), 1), "mean_ms": round(1000 * statistics.mean(lat), 1),
            "throughput_per_s": round(len(lat) / wall, 1)}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--server", help="target this server instead of starting one")
    ap.add_argument("--token", default=os.environ.get("GAITMEND_TOKEN", ""))
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--per-client", type=int, default=10)
    ap.add_argument("--database-url", default="", help="for the server started here (default: SQLite)")
    args = ap.parse_args()
    if args.clients < 1 or args.per_client < 1:
        ap.error("--clients and --per-client must be >= 1")

    proc = None
    base = args.server
    if base is None:
        tmp = tempfile.mkdtemp(prefix="gaitmend-load-")
        port = free_port()
        env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")} | {
            "GAITMEND_DATA_DIR": tmp, "GAITMEND_MAX_QUEUED_PER_OWNER": "1000000"}
        if args.database_url:
            env["GAITMEND_DATABASE_URL"] = args.database_url
        proc = subprocess.Popen([sys.executable, "-c", "from app.cli import main; main()", "serve", "--port", str(port), "--no-worker"],
                                env=env, start_new_session=True)
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{base}/api/health", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline or proc.poll() is not None:
                sys.exit("the server did not start")
            time.sleep(0.3)
    try:
        print(json.dumps(asyncio.run(run(base, args.token, args.clients, args.per_client))))
    finally:
        if proc:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(20)


if __name__ == "__main__":
    main()

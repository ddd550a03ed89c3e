#!/usr/bin/env python
"""Submission latency under load: C concurrent clients each POST /api/jobs N times
(a registered kind's smoke spec, distinct seeds) and we report p50 / p99 / max of the request time.

    python scripts/loadtest.py                       # starts its own `gaitmend serve` (SQLite,
                                                     # embedded broker, no worker) in a temp dir
    python scripts/loadtest.py --server http://127.0.0.1:8000 --token gm_...
    python scripts/loadtest.py --json-out docs/loadtest.json   # appended with where and when

Only submission is measured: jobs stay queued (no worker), so the search does not compete
for the CPU with the API."""

from __future__ import annotations

import argparse
import asyncio
import copy
import functools
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx


@functools.cache
def _base() -> tuple[dict, str | None]:
    """The spec every request submits, of a kind every installation has (no kind named here):
    the first registered kind's smoke spec (the first kind's default spec if none has one),
    and the dotted path of the field its ``seed`` reads (None if no form field is it)."""
    from app.jobs.base import SpecError
    from app.jobs.registry import KINDS
    from app.studies.spec import set_path

    kind = next((k for k in KINDS.values() if k.smoke_spec() is not None), next(iter(KINDS.values())))
    base = kind.smoke_spec() or kind.default_spec().model_dump(mode="json")
    for path in [f["path"] for f in kind.form() if f["path"].split(".")[-1] == "seed"]:
        trial = copy.deepcopy(base)
        set_path(trial, path, 10**6)  # the largest seed submitted (the warm-up's)
        try:
            if getattr(kind.Spec.parse(trial), "seed", None) == 10**6:
                return base, path
        except SpecError:
            continue
    return base, None


def spec(seed: int) -> dict:
    from app.studies.spec import set_path

    base, seed_path = _base()
    out = copy.deepcopy(base)
    if seed_path:
        set_path(out, seed_path, seed)
    return out


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


def start_server(database_url: str, tmp: str) -> tuple[subprocess.Popen, str]:
    """A `gaitmend serve` (embedded broker, no worker) with its data in ``tmp`` on a free port,
    on SQLite or ``database_url``; (its process, its base URL) once it answers /api/health."""
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")} | {
        "GAITMEND_DATA_DIR": tmp, "GAITMEND_MAX_QUEUED_PER_OWNER": "1000000"}
    if database_url:
        env["GAITMEND_DATABASE_URL"] = database_url
    proc = subprocess.Popen([sys.executable, "-c", "from app.cli import main; main()", "serve", "--port", str(port), "--no-worker"],
                            env=env, start_new_session=True)
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            if httpx.get(f"{base}/api/health", timeout=2).status_code == 200:
                return proc, base
        except httpx.HTTPError:
            pass
        if time.monotonic() > deadline or proc.poll() is not None:
            os.killpg(proc.pid, signal.SIGTERM)
            sys.exit("the server did not start")
        time.sleep(0.3)


def measure(args: argparse.Namespace) -> dict:
    """One measurement: the server started here (unless --server), the clients' burst, the
    server stopped and its data folder removed."""
    with tempfile.TemporaryDirectory(prefix="gaitmend-load-") as tmp:
        proc, base = (None, args.server) if args.server else start_server(args.database_url, tmp)
        try:
            return asyncio.run(run(base, args.token, args.clients, args.per_client))
        finally:
            if proc:
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait(20)


def database(args: argparse.Namespace) -> str:
    """The database as a row names it: ``sqlite``, or the URL's scheme, host and port (no user,
    password or database name); a server not started here: unknown."""
    if args.server:
        return f"unknown (--server {args.server})"
    if not args.database_url or args.database_url.startswith("sqlite"):
        return "sqlite"
    from app.cli.study_bench import where

    return where(args.database_url)


def append(args: argparse.Namespace) -> dict:
    """The measurement with its options, the machine, the load, the commit and the date,
    appended to --json-out (written atomically); the row appended."""
    from app.cli.bench import append_measured, measured
    from app.results.loadtest import COMMAND

    options = {"clients": args.clients, "per_client": args.per_client, "database": database(args)}
    data = append_measured(args.json_out, "loadtest", COMMAND, [options], lambda o: measured(lambda: o | measure(args)),
                           lambda o: f"{o['clients']} clients x {o['per_client']} requests, {o['database']}",
                           lambda line: print(line, file=sys.stderr))
    return data["runs"][-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--server", help="target this server instead of starting one")
    ap.add_argument("--token", default=os.environ.get("GAITMEND_TOKEN", ""))
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--per-client", type=int, default=10)
    ap.add_argument("--database-url", default="", help="for the server started here (default: SQLite)")
    ap.add_argument("--json-out", type=Path, help="append the measurement, with the options, the machine, its load "
                                                  "before and after, the niceness, the commit and the date, to this "
                                                  "JSON file (docs/loadtest.json is rendered into docs/benchmarks.md)")
    args = ap.parse_args()
    if args.clients < 1 or args.per_client < 1:
        ap.error("--clients and --per-client must be >= 1")
    print(json.dumps(append(args) if args.json_out else measure(args)))


if __name__ == "__main__":
    main()

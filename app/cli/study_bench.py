"""Dispatch overhead of a study: N tiny points through the real service (API in this
process, one `gaitmend worker` process of concurrency 1, the configured broker and
database). Overhead per point = (wall time from POST until the aggregate is complete
- the sum of every job's own time (claim to finish, as the runner stored it)) / N, and
also against the kinds' compute alone (summary.timing.wall_s).

    python -m app.cli.study_bench BASE_SPEC.json --points 200
(GAITMEND_* variables choose the deployment; the worker inherits them.)

``study_bench`` is what `gaitmend bench --studies --json` prints and what `gaitmend reproduce
bench --kinds studies` appends to docs/benchmarks.json: the figures with the deployment they
were measured on (``deployment``: scheme, host and port only)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import urllib.parse

POINTS, QUICK_POINTS = 200, 6  # the published size; --quick's (a smoke run)


def tiny_spec() -> dict:
    """A job that runs in seconds, of a kind every installation has: the first registered
    kind's smoke spec (the kind contract's)."""
    from app.jobs.registry import KINDS

    return next(k.smoke_spec() for k in KINDS.values() if k.smoke_spec() is not None)


def dispatch_overhead(base: dict, points: int, log=lambda s: None) -> dict:
    """Run the study through a real worker and the API of this process; the figures."""
    from fastapi.testclient import TestClient

    from app.api import create_app
    from app.core.settings import get_settings
    from app.store.db import session_scope
    from app.store.migrate import upgrade
    from app.store.models import utcnow
    from app.studies import store

    settings = get_settings()
    # the bench's points may exceed the per-owner queue limit (they are one owner's)
    settings = settings.model_copy(update={"max_queued_per_owner": max(settings.max_queued_per_owner, points)})
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.db_url)
    study = {"name": "bench", "base": base, "points": [{} for _ in range(points)],
             "report": {"metrics": ["timing.wall_s"]}}
    # points differ only by index: the same spec N times is N real, independent jobs
    since = utcnow()
    worker = subprocess.Popen([sys.executable, "-c", "from app.cli import main; main()", "worker", "--concurrency", "1"],
                              env=os.environ | {"OMP_NUM_THREADS": "1"}, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        client = TestClient(create_app(settings))
        wait_for_workers(settings, 1, since)  # the worker is up (imports) before the clock starts
        log(f"{points} points through one worker ({settings.broker_url.split('@')[-1]}, "
            f"{settings.db_url.split('@')[-1]}) ...")
        t0 = time.monotonic()
        r = client.post("/api/studies", json=study)
        if r.status_code != 201:
            raise RuntimeError(f"the bench study was refused: {r.status_code} {r.text}")
        sid = r.json()["id"]
        while (st := client.get(f"/api/studies/{sid}").json())["status"] in ("queued", "running"):
            time.sleep(0.05)
        wall = time.monotonic() - t0
        with session_scope(settings.db_url, readonly=True) as s:
            jobs = store.study_jobs(s, sid)
            own = sum((j.finished_at - j.started_at).total_seconds() for j in jobs)
            compute = sum(j.summary["timing"]["wall_s"] for j in jobs if j.summary)
        n = len(jobs)
        return {"points": n, "status": st["status"], "wall_s": round(wall, 2),
                "jobs_claim_to_finish_s": round(own, 2), "kind_compute_s": round(compute, 2),
                "overhead_per_point_ms": round(1000 * (wall - own) / n, 1),
                "overhead_vs_kind_compute_ms": round(1000 * (wall - compute) / n, 1),
                "target_ms": 50.0, "met": 1000 * (wall - own) / n <= 50.0}
    finally:
        os.killpg(worker.pid, 9)
        worker.wait()


def wait_for_workers(settings, n: int, since, timeout: float = 120.0) -> None:
    """Until ``n`` workers started after ``since`` are live (each worker's housekeeper writes
    its row once its consumer is connected to the broker: app/service/housekeeping.py), so a
    measurement's clock starts when they can take work; RuntimeError after ``timeout``."""
    from app.store import repo
    from app.store.db import session_scope

    deadline = time.monotonic() + timeout
    while True:
        with session_scope(settings.db_url, readonly=True) as s:
            live = sum(w.started_at >= since for w in repo.workers_seen(s, 60.0))
        if live >= n:
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"{live} of {n} workers came up within {timeout:.0f} s")
        time.sleep(0.2)


def where(url: str) -> str:
    """A server's URL as a measurement records it: scheme, host and port, never the user, the
    password or the database."""
    u = urllib.parse.urlsplit(url)
    return f"{u.scheme}://{u.hostname}" + (f":{u.port}" if u.port else "")


def deployment(settings=None) -> dict:
    """The broker and the database of ``settings`` (default: those the GAITMEND_* variables
    name): the embedded ones (Celery's filesystem transport, SQLite) by their names, a server
    by ``where``."""
    from app.core.settings import get_settings

    s = settings or get_settings()
    sqlite = not s.database_url or s.database_url.startswith("sqlite")
    return {"broker": "embedded (filesystem)" if s.embedded_broker else where(s.broker_url),
            "database": "embedded (SQLite)" if sqlite else where(s.database_url)}


def study_bench(points: int = POINTS, log=lambda s: None) -> dict:
    """`gaitmend bench --studies --json`'s figures: the dispatch overhead of ``points`` points of
    ``tiny_spec`` on the configured deployment, and that deployment."""
    return {"study_dispatch": dispatch_overhead(tiny_spec(), points, log), "deployment": deployment()}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("base", nargs="?", help="base job spec JSON (make it tiny); default: a kind's smoke spec")
    ap.add_argument("--points", type=int, default=POINTS)
    args = ap.parse_args()
    base = json.load(open(args.base)) if args.base else tiny_spec()
    print(json.dumps(dispatch_overhead(base, args.points, log=lambda s: print(s, file=sys.stderr))))


if __name__ == "__main__":
    main()

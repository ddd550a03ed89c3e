"""Parallel scaling of a study: the same points run one after another in one process with
one thread, each writing its job bundle as a worker does (`gaitmend study run --workers 1
--bundles`, GAITMEND_SIM_THREADS=1), then served by N
`gaitmend worker --concurrency 1` processes of one thread each through the configured
broker and database, in one run. Prints both wall times, their ratio and whether the two
aggregates are equal.

    python -m app.cli.study_scaling STUDY --workers 2 --base '{"search": {"generations": 5}}'
(STUDY: a study JSON or a built-in study's name, app/studies/catalog.py; GAITMEND_* variables
choose the deployment: Redis + PostgreSQL for the issue's figure.)"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import urlsplit

from app.core.polling import wait_done
from app.results.scaling import COMMAND, JSON

ENTRY = "from app.cli import main; main()"
ONE_THREAD = {"GAITMEND_SIM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def load_study(name_or_path: str, base: dict) -> dict:
    from app.studies.catalog import builtin_studies

    p = Path(name_or_path)
    if p.is_file():
        study = json.loads(p.read_text())
    elif (study := builtin_studies().get(name_or_path)) is None:
        raise SystemExit(f"{name_or_path}: neither a file nor a built-in study ({', '.join(builtin_studies())})")
    if base:
        study["base"] = merge(study["base"], base)
        study["name"] = (study["name"].split(" (")[0] + " (base changed)")[:200]
    return study


def serial(study_file: Path, out: Path) -> tuple[float, dict]:
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-c", ENTRY, "study", "run", str(study_file), "--workers", "1",
                        "--out", str(out), "--bundles", "--json"], env=os.environ | ONE_THREAD, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if r.returncode != 0:
        raise SystemExit(f"serial run failed ({r.returncode}):\n{r.stderr[-3000:]}")
    return wall, json.loads(r.stdout)["aggregate"]


def served(study: dict, workers: int, log, out: Path | None = None) -> dict:
    from fastapi.testclient import TestClient

    from app.api import create_app
    from app.core.settings import get_settings
    from app.cli.study_bench import wait_for_workers
    from app.store.db import session_scope
    from app.store.migrate import upgrade
    from app.store.models import utcnow
    from app.studies import store

    settings = get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.db_url)
    since = utcnow()
    procs = [subprocess.Popen([sys.executable, "-c", ENTRY, "worker", "--concurrency", "1"],
                              env=os.environ | ONE_THREAD, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              start_new_session=True) for _ in range(workers)]
    try:
        client = TestClient(create_app(settings))
        wait_for_workers(settings, workers, since)  # the workers are up (imports) before the clock starts
        t0 = time.monotonic()
        r = client.post("/api/studies", json=study)
        if r.status_code != 201:
            raise SystemExit(f"submit failed: {r.status_code} {r.text}")
        sid = r.json()["id"]
        st, wall = wait_done(lambda: client.get(f"/api/studies/{sid}").json(),
                             lambda st: f"served: {st['progress']['done']}/{st['progress']['points']} done", log, 1.0, t0)
        if out is not None:  # the served study's bundle and plots, as a user would fetch them
            (out / "served_bundle.zip").write_bytes(client.get(f"/api/studies/{sid}/bundle").content)
            (out / "served_views.json").write_text(json.dumps(client.get(f"/api/studies/{sid}/views").json()))
        with session_scope(settings.db_url, readonly=True) as s:
            jobs = store.study_jobs(s, sid)
            own = sum((j.finished_at - j.started_at).total_seconds() for j in jobs
                      if j.started_at and j.finished_at)
        return {"wall_s": wall, "status": st["status"], "aggregate": st["aggregate"], "jobs_claim_to_finish_s": own,
                "study_id": sid, "points": st["progress"]["points"]}
    finally:
        for p in procs:
            os.killpg(p.pid, 9)
            p.wait()


def bundle_bytes(folder: Path) -> list[int]:
    """The sizes of the job bundles the serial run wrote (zip files under ``folder``)."""
    return sorted(f.stat().st_size for f in folder.rglob("*.zip")) if folder.is_dir() else []


def scaling(study: dict, workers: int, out: Path, served_only: bool, log) -> dict:
    """Both halves of one measurement; the figures as this command prints them."""
    t_serial, agg_serial = None, None
    study_file = out / "study.json"
    study_file.write_text(json.dumps(study))
    if not served_only:
        log(f"serial: {study['name']} in one process with one thread ...")
        t_serial, agg_serial = serial(study_file, out / "serial")
        log(f"serial: {t_serial:.1f} s")
    log(f"served by {workers} one-thread workers ...")
    s = served(study, workers, log, out)
    sizes = bundle_bytes(out / "serial")
    return {"study": study["name"], "points": s["points"], "base": study["base"],
            "workers": workers, "cores": os.cpu_count(),
            "serial_s": None if t_serial is None else round(t_serial, 1), "served_s": round(s["wall_s"], 1),
            "ratio": None if t_serial is None else round(s["wall_s"] / t_serial, 3), "served_status": s["status"],
            "served_jobs_claim_to_finish_s": round(s["jobs_claim_to_finish_s"], 1),
            "same_aggregate": None if agg_serial is None else s["aggregate"] == agg_serial,
            "bundles": len(sizes), "bundle_bytes_median": sizes[len(sizes) // 2] if sizes else None,
            "broker": where(os.environ.get("GAITMEND_BROKER_URL"), "embedded"),
            "database": where(os.environ.get("GAITMEND_DATABASE_URL"), "sqlite")}


def where(url: str | None, default: str) -> str:
    """A deployment's broker or database by scheme and host only (no user, password, path
    or options): "redis (127.0.0.1:6379)", "postgresql (db:5432)"."""
    if not url:
        return default
    u = urlsplit(url)
    scheme = u.scheme.split("+")[0]
    return f"{scheme} ({u.hostname}{f':{u.port}' if u.port else ''})" if u.hostname else scheme


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", help="study JSON or a built-in name")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--base", default="{}", help="JSON merged into the study's base spec (e.g. a smaller budget)")
    ap.add_argument("--out", type=Path, default=None, help="folder for the serial run's files")
    ap.add_argument("--served-only", action="store_true", help="skip the serial run (e.g. to run a long study once)")
    ap.add_argument("--json-out", type=Path, default=None,
                    help=f"append the measurement, with the machine, load, commit and date, to this file "
                         f"({JSON}: docs/studies.md's scaling table)")
    args = ap.parse_args()
    if not 1 <= args.workers <= 64:
        ap.error(f"--workers must be 1..64, got {args.workers}")
    study = load_study(args.study, json.loads(args.base))
    out = args.out or Path(tempfile.mkdtemp(prefix="gaitmend-scaling-"))
    out.mkdir(parents=True, exist_ok=True)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    if args.json_out is None:
        print(json.dumps(scaling(study, args.workers, out, args.served_only, log)))
        return
    from app.cli.bench import append_measured, measured

    data = append_measured(args.json_out, "study-scaling", COMMAND, [study["name"]],
                           lambda _: measured(lambda: scaling(study, args.workers, out, args.served_only, log)),
                           lambda name: f"{name}: serial, then served by {args.workers} workers", log)
    print(json.dumps(data["runs"][-1]))


if __name__ == "__main__":
    main()

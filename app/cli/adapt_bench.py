"""`gaitmend bench --adapt`: how long a lab waits for the next gait (issue 44: "a proposal
is returned within one second of posting a trial, with 20 trials and a map of 10,000
elites"). Adaptation is not a job kind, so its figure is gathered here, beside the study
dispatch bench (app/cli/study_bench.py), and `gaitmend bench` (every kind) includes it.

The path timed is the service's own: POST /api/adaptations/{id}/trials through the app
(create_app, in this process, over HTTP's ASGI interface) on a SQLite store, the trial
written and the next proposal, its prediction and the stop decision computed from the 20
stored trials (app/store/repo/adaptations.py, app/adapt/session.py). The map is a
repertoire job's result in the kind's format with 10,000 elites of the hexapod's 55
parameters; its elites are drawn at random (seeded), since a real map that size takes half
an hour to build and the figure is the session's cost, which depends on the map's size,
not on its gaits. Two sessions over the same map: the warm figure is a post while the
server holds the map read (every post after the first), the cold one the first post after
a restart (the map read again from the job's stored result, as the JSON text it is stored as)."""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ELITES, TRIALS, TARGET_S = 10_000, 20, 1.0
QUICK_ELITES, QUICK_TRIALS = 1_000, 5
REPEATS = 3


def synthetic_summary(n: int, seed: int = 0) -> dict:
    """A repertoire result (app/jobs/repertoire/run.py ``_finish``'s keys that a map is read
    from) with ``n`` random elites over the hexapod's contact descriptor."""
    from app.jobs.registry import get_kind, parse_spec

    rng = np.random.default_rng(seed)
    legs, joints = 6, 18
    dim = 3 * joints + 1
    spec = parse_spec({"kind": "repertoire"})
    kind = get_kind("repertoire")
    names = [f"contact_leg{k + 1}" for k in range(legs)]
    return {
        "robot": {"name": "jethexa", "legs": [f"leg{k + 1}" for k in range(legs)],
                  "joints": [f"leg{k // 3 + 1}_j{k % 3}" for k in range(joints)]},
        "damage": {}, "kind": kind.name,
        "controller": {"joints": [f"leg{k // 3 + 1}_j{k % 3}" for k in range(joints)], "lo": [-1.0] * joints,
                       "hi": [1.0] * joints, "stance": [0.0] * joints, "amplitude": spec.controller.amplitude,
                       "offset": spec.controller.offset, "period_s": list(spec.controller.period_s),
                       "ramp_s": spec.controller.ramp_s, "parameters": dim, "per_joint": 3},
        "descriptor": {"type": "contact", "names": names, "bounds": [[0.0, 1.0]] * legs},
        "trial": {"duration_s": spec.sim.duration_s, "settle_s": spec.sim.settle_s, "timestep_s": 0.002},
        "best": None,
        "elites": {"cell": list(range(n)), "objective": rng.uniform(-0.2, 0.6, n).tolist(),
                   "measures": rng.uniform(0, 1, (n, legs)).tolist(), "solution": rng.uniform(0, 1, (n, dim)).tolist(),
                   "lateral_m": rng.normal(0, 0.05, n).tolist(), "yaw_deg": rng.normal(0, 5, n).tolist(),
                   "fell": [0.0] * n, "energy_j": rng.uniform(1, 10, n).tolist(), "timestep_s": [0.002] * n,
                   "contact": rng.uniform(0, 1, (n, legs)).tolist()},
    }


def _measured(k: int) -> dict:
    # slower than the map predicts and never stopping: every trial up to the 20th is taken
    return {"trial": k, "forward_m": -0.01 * (k % 3), "lateral_m": 0.02, "yaw_deg": 3.0, "fell": False,
            "duration_s": 10.0}


def adapt_bench(quick: bool = False, log: Callable[[str], None] = print) -> dict:
    from fastapi.testclient import TestClient

    from app.adapt import session as S
    from app.api import create_app
    from app.core.settings import load_settings
    from app.store import repo
    from app.store.db import session_scope
    from app.store.migrate import upgrade
    from app.store.models import utcnow

    load_before = os.getloadavg()[0]
    n, trials = (QUICK_ELITES, QUICK_TRIALS) if quick else (ELITES, TRIALS)
    log(f"adapt: a session over a {n:,}-elite map, {trials - 1} trials posted, then trial {trials} timed")
    with tempfile.TemporaryDirectory(prefix="gaitmend-adapt-bench-") as tmp:
        settings = load_settings(data_dir=str(Path(tmp) / "data"), auth="off")
        settings.data_dir.mkdir(parents=True)
        upgrade(settings.db_url)
        summary = synthetic_summary(n)
        with session_scope(settings.db_url) as s:
            job = repo.create_job(s, owner="local", kind="repertoire", robot="jethexa", spec={"kind": "repertoire"},
                                  evaluations_budget=1, max_attempts=1)
            job.status, job.summary, job.finished_at = "succeeded", summary, utcnow()
            jid = job.id
        body = {"repertoires": [jid], "method": "ite", "stop": {"max_trials": 100, "alpha": 1.0}}
        warm, cold = [], []
        with TestClient(create_app(settings)) as c:
            def prepared() -> str:
                sid = c.post("/api/adaptations", json=body).json()["id"]
                for k in range(1, trials):
                    r = c.post(f"/api/adaptations/{sid}/trials", json=_measured(k))
                    assert r.status_code == 201, r.text
                return sid

            def timed(sid: str, into: list) -> dict:
                t0 = time.perf_counter()
                r = c.post(f"/api/adaptations/{sid}/trials", json=_measured(trials))
                into.append(time.perf_counter() - t0)
                assert r.status_code == 201 and r.json()["next"] is not None, r.text
                return r.json()

            for _ in range(REPEATS):
                timed(prepared(), warm)  # the map held in memory, as after any earlier post
                sid = prepared()
                S._CACHE.clear()  # a restarted server: the map read again from the job's stored result
                done = timed(sid, cold)
            prop = done["next"]
    out = {"elites": n, "trials": trials, "warm_s": round(min(warm), 4), "warm_median_s": round(float(np.median(warm)), 4),
           "cold_s": round(min(cold), 4), "target_s": TARGET_S, "met": bool(max(warm) <= TARGET_S), "met_cold": bool(max(cold) <= TARGET_S),
           "repeats": REPEATS, "cores": os.cpu_count(),
           "load_before": round(load_before, 1), "load_after": round(os.getloadavg()[0], 1), "proposal": {"elite": prop["elite"], "predicted_m_s": round(prop["predicted_m_s"], 5)}}
    log(f"adapt: post of trial {trials} {out['warm_s']:.3f} s warm (median {out['warm_median_s']:.3f}), "
        f"{out['cold_s']:.3f} s right after a restart; target <= {TARGET_S:g} s")
    return {"adapt_proposal": out}


def print_figures(figures: dict) -> None:
    print(json.dumps(figures))

"""The runs of the repertoire's reproductions (app/jobs/repertoire/reproduce/experiments.py):
the robots (the built-in hexapod and two uploaded ones), one job run with a checkpoint file,
its elites re-simulated on held-out models, and the compact record a ledger keeps. This
module decides the recorded numbers, so the ledgers' code version hashes it; the
renderers (experiments.py) do not."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from app.jobs.base import MemoryContext, dumps
from app.jobs.ledger import write_json_atomic
from app.robots.upload.samples import sample_robot

HELD_OUT_CASES = ("friction_0.7", "friction_1.3", "mass_+10pct", "mass_-10pct")
KEEPS = 0.5  # a held-out elite "keeps its walk" when it is upright and walks at least half its nominal distance
ROBOT_NAMES = {"jethexa": "jethexa (built-in hexapod)", "dm_quadruped": "dm_control quadruped (uploaded)",
               "gym_ant": "Gymnasium Ant (uploaded)"}


# -- the robots ----------------------------------------------------------------------------------

def robot_of(name: str):
    """(the spec's robot field, the stored robot or None for a built-in)."""
    if name == "jethexa":
        return "jethexa", None
    if name not in ROBOT_NAMES:
        raise ValueError(f"unknown uploaded robot {name!r}: {sorted(ROBOT_NAMES)}")
    return sample_robot(name)


# -- a run ---------------------------------------------------------------------------------------

class FileContext(MemoryContext):
    """A run context whose checkpoints are a JSON file (written atomically): a reproduction
    killed midway resumes the run from its last checkpoint."""

    def __init__(self, path: Path, robots=None):
        super().__init__(robots=robots)
        self.path = Path(path)

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        write_json_atomic(self.path, state)

    def load_checkpoint(self) -> dict[str, Any] | None:
        return json.loads(self.path.read_text()) if self.path.exists() else None


def _thin(history: list[dict], points: int) -> list[dict]:
    """About ``points`` rows of the history, evenly spaced, the last always kept."""
    if len(history) <= points:
        idx = range(len(history))
    else:
        idx = sorted(set(np.linspace(0, len(history) - 1, points).round().astype(int).tolist()))
    keep = ("evaluations", "coverage", "qd_score", "best", "random_coverage", "random_qd_score", "random_best")
    return [{k: history[i][k] for k in keep if k in history[i]} for i in idx]


def _arm(coverage, qd, best, elites) -> dict:
    return {"coverage": coverage, "qd_score": qd, "best_forward_m": best, "elites": elites}


def top_elites(table: dict, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(parameters (k, dim), forward distances (k,)) of the ``k`` best elites (ties by cell)."""
    obj, cells = np.asarray(table["objective"], float), np.asarray(table["cell"])
    order = np.lexsort((cells, -obj))[:k]
    return np.asarray(table["solution"], float)[order], obj[order]


def held_out(spec, stored, table: dict, k: int, cases=HELD_OUT_CASES) -> dict:
    """The ``k`` best elites re-simulated under each named case of the project's vocabulary
    (app/jobs/records.py ``CASES``, made into models by app/sim/perturb.py): models the map
    was not built on. Per case: the elites' median forward distance, how many keep their
    walk (upright, at least ``KEEPS`` of their nominal distance) and how many fall."""
    from app.jobs.evidence import CASES
    from app.jobs.repertoire.body import build
    from app.jobs.repertoire.evaluate import Evaluator
    from app.jobs.repertoire.run import layout_of
    from app.sim.perturb import Perturbation, perturbed_model

    x, nominal = top_elites(table, k)
    out = {"elites": int(len(x)), "keeps": KEEPS, "nominal_median_m": float(np.median(nominal)) if len(x) else None,
           "cases": []}
    if not len(x):
        return out
    body = build(spec, stored)
    layout = layout_of(spec, body)
    for name in cases:
        c = CASES[name]
        p = Perturbation(c.name, c.label, timestep_scale=c.timestep_scale, friction_scale=c.friction_scale,
                         mass_scale=c.mass_scale)
        ev = Evaluator(dataclasses.replace(body, model=perturbed_model(body.mspec, p, body.model)), layout,
                       spec.sim.duration_s, spec.sim.settle_s)
        try:
            m = ev.evaluate(x)
        finally:
            ev.close()
        keeps = (~m["fell"]) & (m["forward_m"] >= KEEPS * nominal)
        out["cases"].append({"name": c.name, "label": c.label, "median_forward_m": float(np.median(m["forward_m"])),
                             "keeps": int(np.sum(keeps)), "fell": int(np.sum(m["fell"])),
                             "forward_m": m["forward_m"].tolist()})
    return out


def run_one(data: dict, robot_name: str, stored, checkpoint: Path | None, held_out_elites: int,
            history_points: int) -> dict:
    """One job (MAP-Elites and its random control, same budget, same centroids), its
    elites re-simulated on the held-out cases, compacted to what the docs use."""
    import time

    from app.jobs.repertoire.body import build
    from app.jobs.repertoire.run import run
    from app.jobs.repertoire.spec import RepertoireSpec

    spec = RepertoireSpec.parse(data)
    robots = (lambda rid: stored) if stored is not None else None
    ctx = FileContext(checkpoint, robots) if checkpoint is not None else MemoryContext(robots=robots)
    resumed = ctx.load_checkpoint()
    load_before, t0 = os.getloadavg()[0], time.perf_counter()
    r = run(spec, ctx)
    wall = time.perf_counter() - t0
    load_after = os.getloadavg()[0]
    s, hist = json.loads(dumps(r.summary)), json.loads(dumps(r.history))
    ctl = next(c["metrics"] for c in s["controls"] if c["name"] == "random_search")
    a = s["archive"]
    t0 = time.perf_counter()
    ho = held_out(spec, stored, s["elites"], held_out_elites)
    ho["wall_s"] = time.perf_counter() - t0
    tc = {k: v for k, v in s["timestep_check"].items() if k not in ("cells",)}
    model_xml = build(spec, stored).mspec.to_xml()
    per_arm = spec.search.iterations * spec.search.batch_size
    return {
        "robot": robot_name, "robot_info": {k: s["robot"].get(k) for k in ("name", "built_in", "legs", "servos")},
        "model_sha256": hashlib.sha256(model_xml.encode()).hexdigest(),
        "budget": {"evaluations_per_arm": per_arm, "iterations": spec.search.iterations,
                   "batch_size": spec.search.batch_size, "cells": spec.archive.cells,
                   "parameters": s["controller"]["parameters"], "duration_s": spec.sim.duration_s,
                   "settle_s": spec.sim.settle_s, "timestep_s": spec.sim.timestep_s,
                   "emitter": spec.search.emitter, "iso_sigma": spec.search.iso_sigma,
                   "line_sigma": spec.search.line_sigma},
        "arms": {"map_elites": _arm(a["coverage"], a["qd_score"], a["best_forward_m"], a["elites"]),
                 "random": _arm(ctl["coverage"], ctl["qd_score"], ctl["best_forward_m"], ctl["elites"])},
        "convergence": _thin(hist, history_points),
        "timestep_check": tc,
        "held_out": ho,
        "timing": {"wall_s": wall, "evaluations": r.evaluations, "evaluations_per_s": r.evaluations / wall,
                   "threads": _threads(), "cores": os.cpu_count(), "load_before": load_before,
                   "load_after": load_after,
                   "resumed_from_iteration": resumed["iteration"] if resumed else None},
    }


def _threads() -> int:
    from app.sim.threads import sim_threads

    return sim_threads()


def emitter_job(data: dict) -> dict:
    from app.jobs.repertoire.run import run
    from app.jobs.repertoire.spec import RepertoireSpec

    s = json.loads(dumps(run(RepertoireSpec.parse(data), MemoryContext()).summary))
    a = s["archive"]
    out = {"map_elites": _arm(a["coverage"], a["qd_score"], a["best_forward_m"], a["elites"])}
    for c in s["controls"]:
        if c["name"] == "random_search":
            m = c["metrics"]
            out["random"] = _arm(m["coverage"], m["qd_score"], m["best_forward_m"], m["elites"])
    return out


def timestep_job(data: dict) -> dict:
    """A short map at the spec's step and its best elites re-scored at half the step
    (the job's own timestep check): per elite, both forward distances; how many stay in
    their cell and fall; the job's rate."""
    import time

    from app.jobs.repertoire.run import run
    from app.jobs.repertoire.spec import RepertoireSpec

    spec = RepertoireSpec.parse(data)
    t0 = time.perf_counter()
    r = run(spec, MemoryContext())
    wall = time.perf_counter() - t0
    c = json.loads(dumps(r.summary))["timestep_check"]
    return {k: c[k] for k in ("timestep_s", "half_timestep_s", "elites", "forward_m", "forward_half_m", "same_cell",
                              "fell_at_half")} | {"wall_s": wall, "evaluations": r.evaluations,
                                                  "load": os.getloadavg()[0]}

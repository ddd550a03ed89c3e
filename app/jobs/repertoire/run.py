"""The ``repertoire`` job: MAP-Elites (pyribs) over the periodic joint-space controller,
its random-search control at the same budget, and the best elites re-scored at half the
timestep.

Each iteration asks the emitter for ``batch_size`` gaits (the first: uniform random gaits)
and draws as many uniform random gaits for the control, scores both in one batched
rollout, tells pyribs the map's and adds the control's to its own archive (same
centroids). Every random draw comes from the job's seed: iteration k's emitter, its
parent draws in the archive and its first gaits from SeedSequence((seed, k, i)), the
control's from (control_seed(seed), k); nothing random carries from one iteration to the
next but the archives, so a checkpoint (the archives, exactly, and the history) resumes
bit-identically.
"""

from __future__ import annotations

import time

import numpy as np

from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.evidence import ControlRow, control_seed
from app.jobs.repertoire import archive as arc
from app.jobs.repertoire.body import Body, build
from app.jobs.repertoire.controller import Layout
from app.jobs.repertoire.evaluate import Evaluator, descriptor_ranges, descriptors
from app.jobs.repertoire.spec import BUILTIN, RepertoireSpec

CHECKPOINT_VERSION = 1


def layout_of(spec: RepertoireSpec, body: Body) -> Layout:
    c = spec.controller
    return Layout(body.lo, body.hi, body.stance, c.amplitude, c.offset, c.period_s, c.ramp_s, body.joints)


def centroid_seed(spec: RepertoireSpec) -> int:
    """The centroids' seed: the spec's own, or the job's (islands of one map share theirs)."""
    c = spec.archive.centroid_seed
    return spec.seed if c is None else c


def _seed(*words: int) -> int:
    return int(np.random.SeedSequence([int(w) for w in words]).generate_state(1)[0])


def ask(archive, spec: RepertoireSpec, dim: int, it: int) -> np.ndarray:
    """Iteration ``it``'s gaits from the map's emitter. Neither emitter learns from what it
    is told (their ``tell`` does nothing), so the gaits are offered to the archive directly
    (``archive.add``: only the admissible ones, app/jobs/repertoire/archive.py) rather than
    through a scheduler, which would offer every gait."""
    from ribs.emitters import GaussianEmitter, IsoLineEmitter

    s = spec.search
    # pyribs draws parents with the archive's own generator: seeded per iteration (module doc)
    archive._rng = np.random.default_rng(_seed(spec.seed, it, 2))
    first = np.random.default_rng(_seed(spec.seed, it, 3)).uniform(size=(s.batch_size, dim))
    common = dict(initial_solutions=first, bounds=[(0.0, 1.0)] * dim, batch_size=s.batch_size,
                  seed=_seed(spec.seed, it, 1))
    if s.emitter == "iso_line":
        emitter = IsoLineEmitter(archive, iso_sigma=s.iso_sigma, line_sigma=s.line_sigma, **common)
    else:
        emitter = GaussianEmitter(archive, sigma=s.sigma, **common)
    return np.asarray(emitter.ask(), dtype=float)


def run(spec: RepertoireSpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    stored = ctx.load_robot(spec.robot) if spec.robot not in BUILTIN else None
    body = build(spec, stored)
    layout = layout_of(spec, body)
    ev = Evaluator(body, layout, spec.sim.duration_s, spec.sim.settle_s)
    try:
        return _run(spec, ctx, body, layout, ev, stored, t0)
    finally:
        ev.close()


def _run(spec, ctx, body, layout, ev, stored, t0) -> JobResult:
    names, ranges = descriptor_ranges(spec.descriptor, body.legs)
    dim, floor = layout.dim, spec.archive.min_forward_m
    ckpt = ctx.load_checkpoint()
    if ckpt and ckpt.get("version") != CHECKPOINT_VERSION:
        ckpt = None
    points = (np.asarray(ckpt["centroids"]) if ckpt
              else arc.centroids(spec.archive.cells, ranges, centroid_seed(spec)))
    main = arc.make(points, dim, ranges, len(body.legs), floor, spec.seed)
    rand = arc.make(points, dim, ranges, len(body.legs), floor, control_seed(spec.seed))
    it, evaluations, history = 0, 0, []
    if ckpt:
        arc.restore(main, ckpt["map"])
        arc.restore(rand, ckpt["random"])
        it, evaluations, history = ckpt["iteration"], ckpt["evaluations"], ckpt["history"]
    s, control = spec.search, spec.evidence.random_control
    total = spec.evaluations_budget
    while it < s.iterations:
        if ctx.is_cancelled():
            raise Cancelled()
        xs = ask(main, spec, dim, it)
        xr = np.random.default_rng(_seed(control_seed(spec.seed), it)).uniform(size=(s.batch_size, dim))
        both = np.concatenate([xs, xr]) if control else xs
        m = ev.evaluate(both)
        n = len(xs)
        mine = {k: v[:n] for k, v in m.items()}
        arc.add(main, xs, mine, descriptors(mine, spec.descriptor), floor, spec.archive.admit_fallen)
        if control:
            theirs = {k: v[n:] for k, v in m.items()}
            arc.add(rand, xr, theirs, descriptors(theirs, spec.descriptor), floor, spec.archive.admit_fallen)
        it += 1
        evaluations += len(both)
        history.append(_row(it, n * it, main, rand if control else None, floor, mine))
        ctx.progress(evaluations, total, {"iteration": it, "coverage": history[-1]["coverage"],
                                          "qd_score": history[-1]["qd_score"], "best_m": history[-1]["best"]})
        if it % s.checkpoint_every == 0 or it == s.iterations:
            ctx.save_checkpoint({"version": CHECKPOINT_VERSION, "iteration": it, "evaluations": evaluations,
                                 "history": history, "centroids": points.tolist(), "map": arc.dump(main),
                                 "random": arc.dump(rand)})
    if ctx.is_cancelled():
        raise Cancelled()
    summary, traces, extra = _finish(spec, body, layout, ev, main, rand, names, ranges, stored)
    evaluations += extra
    wall = time.perf_counter() - t0
    summary["timing"] = {"wall_s": wall, "evaluations_per_s": evaluations / wall if wall > 0 else None}
    return JobResult(summary=summary, history=history, traces=traces, model_xml=body.mspec.to_xml(),
                     evaluations=evaluations, sim_steps=evaluations * ev.nstep)


def _row(it: int, evals: int, main, rand, floor: float, m: dict) -> dict[str, float]:
    a = arc.stats(main, floor)
    row = {"iteration": it, "evaluations": evals, "elites": a["elites"], "coverage": a["coverage"],
           "qd_score": a["qd_score"], "best": a["best"] if a["best"] is not None else floor,
           "fell": int(np.sum(m["fell"]))}
    if rand is not None:
        r = arc.stats(rand, floor)
        row |= {"random_coverage": r["coverage"], "random_qd_score": r["qd_score"],
                "random_best": r["best"] if r["best"] is not None else floor}
    return row


def _best(archive) -> dict | None:
    if archive.empty:
        return None
    e = archive.best_elite
    return {"cell": int(e["index"]), "params": np.asarray(e["solution"]).tolist(),
            "descriptor": np.asarray(e["measures"]).tolist(), "forward_m": float(e["objective"]),
            "metrics": {k: (bool(e[k]) if k == "fell" else float(e[k])) for k in arc.SCALARS}
            | {"contact": np.asarray(e["contact"]).tolist()}}


def _finish(spec, body, layout, ev, main, rand, names, ranges, stored):
    """The summary, the best gait's trace and the evaluations spent after the search."""
    floor = spec.archive.min_forward_m
    a, extra, traces = arc.stats(main, floor), 0, {}
    best = _best(main)
    check = timestep_check(spec, body, layout, main, spec.evidence.rescore_elites)
    extra += check["elites"]
    if best is not None:
        traces["best"] = ev.record(np.asarray(best["params"]))
        extra += 1
    from app.jobs.repertoire.play import elite_traces  # the job page replays elites picked on the map

    traces |= elite_traces(ev, arc.table(main), ranges)
    controls = []
    if spec.evidence.random_control:
        r = arc.stats(rand, floor)
        n = spec.search.iterations * spec.search.batch_size
        controls.append(ControlRow(
            "random_search", "uniform random gaits, same budget, same archive", target_met=None, evaluations=n,
            metrics={"coverage": r["coverage"], "qd_score": r["qd_score"], "best_forward_m": r["best"],
                     "elites": r["elites"]},
            note="each iteration's gaits drawn uniformly from the controller's unit cube (control_seed)").to_json())
    summary = {
        "robot": body.info | {"joints": body.joints},
        "damage": spec.damage.model_dump(),
        "controller": layout.to_json() | {"parameters": layout.dim, "per_joint": 3},
        "descriptor": {"type": spec.descriptor.type, "names": names, "bounds": [list(b) for b in ranges]},
        "archive": {"cells": spec.archive.cells, "elites": a["elites"], "coverage": a["coverage"],
                    "qd_score": a["qd_score"], "qd_offset_m": floor, "best_forward_m": a["best"],
                    "centroid_samples": max(arc.MIN_SAMPLES, arc.SAMPLES_PER_CELL * spec.archive.cells)},
        "search": {"emitter": spec.search.emitter, "batch_size": spec.search.batch_size,
                   "iterations": spec.search.iterations,
                   "evaluations": spec.search.iterations * spec.search.batch_size},
        "trial": {"duration_s": spec.sim.duration_s, "settle_s": spec.sim.settle_s, "timestep_s": ev.dt},
        "best": best,
        "controls": controls,
        "timestep_check": check,
        "elites": arc.table(main),
    }
    return summary, traces, extra


def timestep_check(spec, body: Body, layout: Layout, archive, k: int) -> dict:
    """The ``k`` best elites scored again with the timestep halved (the same model
    otherwise): how far their forward distance moves and whether they stay in their cell."""
    dt = float(body.model.opt.timestep)
    out = {"timestep_s": dt, "half_timestep_s": dt / 2, "elites": 0}
    if k <= 0 or archive.empty:
        return out
    data = archive.data()
    order = np.lexsort((np.asarray(data["index"]), -np.asarray(data["objective"])))[:k]
    x = np.asarray(data["solution"])[order]
    half_model = body.mspec.compile()
    half_model.opt.timestep = dt / 2
    import dataclasses

    half = Evaluator(dataclasses.replace(body, model=half_model), layout, spec.sim.duration_s, spec.sim.settle_s)
    try:
        m = half.evaluate(x)
    finally:
        half.close()
    f0 = np.asarray(data["objective"])[order]
    diff = m["forward_m"] - f0
    cells = archive.index_of(descriptors(m, spec.descriptor))
    return out | {"elites": int(len(order)), "cells": np.asarray(data["index"])[order].tolist(),
                  "forward_m": f0.tolist(), "forward_half_m": m["forward_m"].tolist(),
                  "abs_diff_m": {"median": float(np.median(np.abs(diff))), "max": float(np.max(np.abs(diff)))},
                  "same_cell": int(np.sum(cells == np.asarray(data["index"])[order])),
                  "fell_at_half": int(np.sum(m["fell"]))}

"""The ``recovery`` kind's figures for `gaitmend bench` (targets live here, not in tests),
sized to be quick beside the one paper-size search it must run (that search's time, with
the machine's load, is ``paper_recovery_wall_s`` in docs/benchmarks.json):

(a) raw native-rollout steps/s on the damaged model (legs 1 and 6 lost), all cores, with
    controls precomputed outside the timer; (b) the evaluator's steps/s including
    trajectory generation, IK, chunking and metrics; (c) ``ratio`` = b / a (30 random
    candidates, full 10 s walks, measured twice, interleaved);
(d) ``paper_recovery_wall_s``: the exact paper DE (30 x 60, full 10 s walks), once, with its
    final F and whether it meets the target;
(e) ``time_to_target_median_s``: the fast preset (stop at the target, confirmed at half the
    step) on the four Table II damages x 3 seeds, with the range, and whether every answer
    meets the target at the default step and at half of it;
(f) peers on the same evaluator, budget and stop rule (legs 1 & 6, 3 seeds): scipy's
    differential_evolution and CMA-ES; their time to the target over ours (median, range);
(g) ``equal_quality_wall_s``: the equal-quality configuration (speed.EQUAL) on legs 1 & 6,
    seed 0, stopped once its best reaches (d)'s F, its answer meeting the target at the
    default step and at half of it: the time to an answer as good as the exact paper DE's
    (None when its budget ends first);
(h) ``recommended_cost_ratio``: issue 47's cost of the recommended mode, today's default job
    (legs 1 & 6, every phase: the search, the random-search control, the named cases, the
    held-out models) and the same spec in the recommended mode (closed loop, robust choice),
    back to back: their wall times and the ratio.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from app.jobs.base import BenchEntry, MemoryContext
from app.jobs.recovery.reproduce.peers import ONLY_SEARCH, scipy_de, timed_search
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.speed_measurements import EQUAL, throughput

SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]  # paper 000's Table II
QUICK = {"search": {"population": 6, "generations": 2}, "sim": {"duration_s": 2.0}}


def _spec(quick: bool, **data) -> RecoverySpec:
    data = {**ONLY_SEARCH, **data}
    if quick:
        data["search"] = {**data.get("search", {}), **QUICK["search"]}
        data["sim"] = QUICK["sim"]
    return RecoverySpec(**data)


def _walk(s: dict) -> dict:
    m = s["best"]["metrics"]
    return {"fitness": s["best"]["fitness"], "target_met": s["best"]["target_met"], "x_cm": 100 * m["x_f_m"],
            "y_cm": 100 * m["y_f_m"], "yaw_deg": m["yaw_f_deg"], "evaluations": s["timing"]["evaluations"],
            "sim_steps": s["timing"]["sim_steps"], "generations_run": s["search"]["generations_run"],
            "stop_reason": s["search"]["stop_reason"]}


def paper_search(quick: bool) -> dict:
    """(d) the exact paper DE on legs 1 & 6, seed 0 (the default job's search)."""
    t = time.perf_counter()
    s = run(_spec(quick, damage={"lost_legs": [1, 6]}), MemoryContext()).summary
    return {"paper_recovery_wall_s": time.perf_counter() - t, "paper": _walk(s), "baseline_fitness":
            s["baseline"]["fitness"]}


def _spread(values: list[float]) -> dict:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)} if values else {}


def fast_preset(quick: bool, seeds: int = 3, log: Callable[[str], None] = print) -> dict:
    """(e) the fast preset on the four Table II damages x ``seeds``; each answer judged again
    at the default step and at half of it after the search."""
    runs = []
    for seed in range(seeds):
        for lost in SCENARIOS:
            spec = _spec(quick, preset="fast", damage={"lost_legs": list(lost)}, search={"seed": seed})
            r = timed_search(spec) | {"lost_legs": list(lost), "seed": seed}
            runs.append(r)
            log(f"  fast preset, legs {lost} seed {seed}: {r['stop_reason']} after {r['generations_run']} generations, "
                f"{r['wall_s']:.1f} s, target {r['target_met']} (half step {r['half_step_met']})")
    times = [r["time_to_target_s"] for r in runs if r["time_to_target_s"] is not None]
    return {"time_to_target_median_s": statistics.median(times) if len(times) == len(runs) else None,
            "fast": {"time_to_target_s": _spread(times), "runs": runs, "reached": f"{len(times)}/{len(runs)}",
                     "all_met_at_half_step": all(r["half_step_met"] for r in runs),
                     "wall_s": _spread([r["wall_s"] for r in runs])}}


def _cmaes_run(quick: bool, seed: int) -> dict:
    spec = _spec(quick, preset="fast", damage={"lost_legs": [1, 6]}, search={"optimizer": "cmaes", "seed": seed,
                                                                            "population": 30})
    return timed_search(spec)


def _scipy_run(quick: bool, seed: int) -> dict:
    """scipy's DE (peers.scipy_de: currenttobest1bin, our population, CR and F, same
    evaluator) stopped by the same rule: the best meets the target at the step, then at half
    of it (that confirmation walk counts as an evaluation)."""
    from app.jobs.recovery.metrics import TARGET
    from app.jobs.recovery.run import _half_step_evaluator, set_up

    spec = _spec(quick, preset="fast", damage={"lost_legs": [1, 6]}, search={"seed": seed})
    job = set_up(spec)
    half = job.half_ev = _half_step_evaluator(job)
    count = {"confirmations": 0, "met_at": None}
    t0 = time.perf_counter()

    def met(x: np.ndarray, m: dict | None) -> bool:
        if m is None or not TARGET.met(m):
            return False
        count["confirmations"] += 1
        ok = TARGET.met({k: v[0] for k, v in half.evaluate(x).metrics.items()})
        if ok:
            count["met_at"] = time.perf_counter() - t0
        return ok

    try:
        out = scipy_de(job, seed, stop=met)
    finally:
        job.close()
    return {"fitness": out["fitness"], "time_to_target_s": count["met_at"],
            "evaluations": out["evaluations"] + count["confirmations"], "wall_s": time.perf_counter() - t0}


def peers(quick: bool, ours: list[dict], seeds: int = 3) -> dict:
    """(f) on legs 1 & 6 over ``seeds``: time to target of scipy's DE and of CMA-ES, and
    theirs over ours (the fast preset's runs on the same damage and seeds)."""
    mine = [r["time_to_target_s"] for r in ours if r["lost_legs"] == [1, 6] and r["seed"] < seeds]
    out = {}
    for name, one in (("scipy_de", _scipy_run), ("cmaes", _cmaes_run)):
        runs = [one(quick, seed) for seed in range(seeds)]
        times = [r["time_to_target_s"] for r in runs]
        ratios = [t / m for t, m in zip(times, mine) if t is not None and m]
        out[name] = {"runs": runs, "time_to_target_s": _spread([t for t in times if t is not None]),
                     "reached": f"{sum(t is not None for t in times)}/{len(times)}",
                     "ratio_to_ours": _spread(ratios)}
    return out


def equal_quality(quick: bool, paper_f: float) -> dict:
    """(g) the equal-quality configuration on legs 1 & 6, seed 0, stopped once its best
    reaches the exact paper DE's F; it counts if that answer meets the target at the
    default step and at half of it."""
    cfg = EQUAL if not quick else {"search": {"optimizer": "cmaes"}}
    spec = _spec(quick, damage={"lost_legs": [1, 6]}, stop={"target": paper_f}, **cfg)
    r = timed_search(spec)
    ok = r["fitness"] >= paper_f and r["target_met"] and bool(r["half_step_met"])
    return {"equal_quality_wall_s": r["wall_s"] if ok else None, "equal_quality": r | {
        "config": cfg, "paper_fitness": paper_f, "reached": ok}}


def recommended_cost(quick: bool) -> dict:
    """(h) today's default job and the same job in the recommended mode, each once, back to
    back on this machine; with each answer's target and held-out figures."""
    from app.jobs.recovery.reproduce.recommended_check import RECOMMENDED

    out: dict = {}
    for name, extra in (("default", {}), ("recommended", RECOMMENDED)):
        data = extra | ({"search": QUICK["search"], "sim": QUICK["sim"]} if quick else {})
        t = time.perf_counter()
        s = run(RecoverySpec.parse(data), MemoryContext()).summary
        out[f"{name}_job_wall_s"] = time.perf_counter() - t
        held = s["robustness"]["held_out"]
        out[name] = {"target_met": s["best"]["target_met"], "evaluations": s["timing"]["evaluations"],
                     "sim_steps": s["timing"]["sim_steps"], "held_out_met": f"{held['met']}/{held['n']}",
                     "held_out_fell": sum(1 for m in held["models"] if m["metrics"]["fell"])}
    out["recommended_cost_ratio"] = out["recommended_job_wall_s"] / out["default_job_wall_s"]
    return out


def bench_recovery(quick: bool = False, log: Callable[[str], None] = print) -> dict:
    t0 = time.perf_counter()
    figures: dict = {}
    log("(a-c) rollout vs evaluator throughput ...")
    figures |= throughput(_spec(quick, damage={"lost_legs": [1, 6]}), repeats=1 if quick else 2)
    log("(d) the exact paper DE (30 x 60, full 10 s walks) ..." if not quick else "(d) small exact DE ...")
    figures |= paper_search(quick)
    log("(e) the fast preset on the four Table II damages x 3 seeds ...")
    figures |= fast_preset(quick, seeds=1 if quick else 3, log=log)
    log("(f) scipy's DE and CMA-ES, same evaluator, budget and stop rule ...")
    figures["peers"] = peers(quick, figures["fast"]["runs"], seeds=1 if quick else 3)
    log("(g) equal quality: the exact paper DE's F and the target, for less ...")
    figures |= equal_quality(quick, figures["paper"]["fitness"])
    log("(h) the recommended mode's cost: today's default job and the same job closed loop with the robust choice ...")
    figures["recommended_cost"] = recommended_cost(quick)
    figures["bench_wall_s"] = time.perf_counter() - t0
    if not quick:
        figures["targets"] = _targets(figures)
    return figures


def _targets(f: dict) -> dict:
    """Issue 22's targets (two idle cores) next to the figures."""
    eq = f["equal_quality_wall_s"]
    ttt = f["time_to_target_median_s"]
    return {"ratio_min": 0.9, "ratio_met": f["ratio"] >= 0.9,
            "paper_recovery_wall_s_max": 120.0, "paper_recovery_met": f["paper_recovery_wall_s"] <= 120.0,
            "time_to_target_median_s_max": 20.0, "time_to_target_met": ttt is not None and ttt <= 20.0
            and f["fast"]["all_met_at_half_step"],
            "equal_quality_wall_s_max": 60.0, "equal_quality_met": eq is not None and eq <= 60.0,
            "bench_wall_s_max": 240.0, "bench_met": f["bench_wall_s"] <= 240.0}


BENCH = [BenchEntry("recovery", "rollout vs evaluator throughput, the exact paper DE, time to target with the fast "
                                "preset, scipy's DE and CMA-ES as peers, equal quality for less", bench_recovery)]

"""The ``recovery`` kind's figures for `gaitmend bench` (targets live here, not in tests).

(a) raw native-rollout steps/s on the damaged model (legs 1 and 6 lost), all cores, with
    controls precomputed outside the timer; (b) the evaluator's steps/s including
    trajectory generation, IK, chunking and metrics; (c) b / a; (d) wall time of a
    paper-size recovery (DE 30 x 60, 10 s); (e) scipy's differential_evolution
    (currenttobest1bin, same population, generations, CR, F and evaluator) as a peer.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np

from app.jobs.base import BenchEntry, MemoryContext
from app.jobs.recovery.run import damage_spec, run, search_bounds, sim_config
from app.jobs.recovery.spec import RecoverySpec


def _setup(spec: RecoverySpec):
    from app.jobs.recovery.sequences import plan_hexapod
    from app.robots.catalog import get_robot
    from app.jobs.recovery.evaluate import GaitEvaluator

    robot = get_robot(spec.robot)
    _, model = robot.model(damage_spec(spec))
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    return robot, GaitEvaluator(robot, model, seq, sim_config(spec))


def throughput(spec: RecoverySpec, repeats: int = 3) -> dict:
    from mujoco import rollout

    robot, ev = _setup(spec)
    lower, upper = search_bounds(spec, robot)
    rng = np.random.default_rng(0)
    x = lower + rng.random((spec.search.population, lower.size)) * (upper - lower)
    ctrl, state = ev.controls(x)
    raw, evaluator = [], []
    with rollout.Rollout(nthread=ev.nthread) as runner:
        runner.rollout(ev.model, ev._datas, state, ctrl[:, :10])  # warm the pool
        for _ in range(repeats):
            t = time.perf_counter()
            runner.rollout(ev.model, ev._datas, state, ctrl)
            raw.append(ctrl.shape[0] * ctrl.shape[1] / (time.perf_counter() - t))
            t = time.perf_counter()
            r = ev.evaluate(x)
            evaluator.append(r.sim_steps / (time.perf_counter() - t))
    ev.close()
    a, b = float(np.median(raw)), float(np.median(evaluator))
    return {"raw_steps_per_s": a, "evaluator_steps_per_s": b, "ratio": b / a, "threads": ev.nthread}


def scipy_peer(spec: RecoverySpec) -> dict:
    from scipy.optimize import differential_evolution

    from app.jobs.recovery.metrics import fitness

    robot, ev = _setup(spec)
    lower, upper = search_bounds(spec, robot)
    s = spec.search
    w, units = spec.objective.weights, spec.objective.units

    evaluations = 0

    def neg_f(xt):  # vectorized: xt is (D, S), one batched rollout per generation
        nonlocal evaluations
        evaluations += np.asarray(xt).shape[1]
        return -fitness(ev.evaluate(np.asarray(xt).T).metrics, w, units)

    t = time.perf_counter()
    res = differential_evolution(
        neg_f, list(zip(lower, upper)), strategy="currenttobest1bin", popsize=max(1, s.population // lower.size),
        maxiter=s.generations, mutation=s.f, recombination=s.cr, seed=s.seed, polish=False, init="random",
        tol=0, atol=0, updating="deferred", vectorized=True)
    wall = time.perf_counter() - t
    ev.close()
    return {"scipy_de_wall_s": wall, "scipy_de_fitness": float(-res.fun), "scipy_de_evaluations": evaluations,
            "scipy_de_population": max(1, s.population // lower.size) * lower.size}


def bench_recovery(quick: bool = False, log: Callable[[str], None] = print) -> dict:
    # The search alone (the paper's algorithm): the random-search control doubles a job's
    # simulations and the robustness block adds about 11 walks' worth; both are off here.
    only_search = {"controls": {"random_search": False}, "robustness": {"cases": []}}
    if quick:
        spec = RecoverySpec(damage={"lost_legs": [1, 6]}, search={"population": 10, "generations": 2},
                            sim={"duration_s": 2.0}, **only_search)
    else:
        spec = RecoverySpec(damage={"lost_legs": [1, 6]}, **only_search)
    figures: dict = {}
    log("(a-c) rollout vs evaluator throughput ...")
    figures |= throughput(spec, repeats=1 if quick else 3)
    log("(d) paper-size recovery (DE 30 x 60, 10 s) ..." if not quick else "(d) small recovery ...")
    t = time.perf_counter()
    s = run(spec, MemoryContext()).summary
    figures["paper_recovery_wall_s"] = time.perf_counter() - t
    figures["de_fitness"] = s["best"]["fitness"]
    figures["de_evaluations"] = s["timing"]["evaluations"]
    figures["baseline_fitness"] = s["baseline"]["fitness"]
    log("(e) scipy differential_evolution, same budget and evaluator ...")
    figures |= scipy_peer(spec)
    if not quick:
        figures["targets"] = {"ratio_min": 0.9, "paper_recovery_wall_s_max": 90.0,
                              "ratio_met": figures["ratio"] >= 0.9,
                              "paper_recovery_met": figures["paper_recovery_wall_s"] <= 90.0}
    return figures


BENCH = [BenchEntry("recovery", "rollout vs evaluator throughput, a paper-size recovery, scipy's DE as a peer",
                    bench_recovery)]

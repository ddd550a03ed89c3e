"""Peers of the paper's DE on one evaluator: scipy's ``differential_evolution``
(app/optim/scipy_de.py) and CMA-ES (app/optim/cmaes.py through the same search loop as our
DE), on the same robot model, bounds, objective (Eq. 5), timestep and walk, each answer
walked again at the step and at half of it. `gaitmend bench` runs them to the target
(bench.py); the equal-budget Table II comparison (peers_check.py, `gaitmend reproduce
recovery-peers`) runs them at the paper's budget: population x (generations + 1) walks,
30 x 61 = 1830.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np

from app.jobs.base import MemoryContext
from app.jobs.recovery.spec import RecoverySpec

# The search alone: the random-search control doubles a job's simulations and the
# robustness block adds about 11 walks' worth; both are off for a peer's run.
ONLY_SEARCH = {"controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 0}}
METHODS = ("scipy_de", "cmaes")
KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "tilt_max_deg", "fell")  # the metrics a peer's run records


def judged(job, x: np.ndarray) -> dict:
    """``x`` walked again on the job's model at the step and at half of it: the metrics at
    the step (``KEEP``) and whether the target is met at each."""
    from app.jobs.recovery.metrics import TARGET
    from app.jobs.recovery.run import _half_step_evaluator

    at = {k: v[0] for k, v in job.ev.evaluate(x).metrics.items()}
    half_ev = job.half_ev or _half_step_evaluator(job)
    half = {k: v[0] for k, v in half_ev.evaluate(x).metrics.items()}
    half_ev.close()
    return {"target_met": TARGET.met(at), "half_step_met": TARGET.met(half), "x_cm": 100 * float(at["x_f_m"]),
            "y_cm": 100 * float(at["y_f_m"]), "yaw_deg": float(at["yaw_f_deg"]),
            "metrics": {k: (bool(at[k]) if k == "fell" else float(at[k])) for k in KEEP}}


def timed_search(spec: RecoverySpec) -> dict:
    """The search alone (set-up, the spec's optimiser through the search loop, then its
    answer judged at the default step and at half of it): what a time to the target, to a
    quality or an equal-budget comparison is about."""
    from app.jobs.evidence import Phases
    from app.jobs.recovery.run import phase_sizes, search, set_up

    t = time.perf_counter()
    job = set_up(spec)
    try:
        search(job, Phases(MemoryContext(), phase_sizes(spec)))
        out = job.searches["search"]
        j = judged(job, out.best_x)
        params = dict(zip(job.names, map(float, out.best_x)))
    finally:
        job.close()
    return {"fitness": out.best_fitness} | j | {
        "evaluations": out.evaluations, "sim_steps": int(out.totals.get("sim_steps", 0)),
        "generations_run": out.generations_run, "stop_reason": out.stop_reason,
        "time_to_target_s": out.time_to_target_s, "search_wall_s": out.wall_s, "best_params": params,
        "wall_s": time.perf_counter() - t}


def scipy_de(job, seed: int, stop: Callable[[np.ndarray, dict | None], bool] | None = None) -> dict:
    """scipy's DE (app/optim/scipy_de.py: set up as our DE) on ``job``'s scorer and bounds,
    with the spec's population, generations, F and CR. ``stop(best_x, its metrics)`` is
    asked after every generation; True ends the search. Every walk counts in
    ``evaluations`` and ``sim_steps``."""
    from app.optim import scipy_de as peer

    s = job.spec.search
    seen: dict[bytes, dict] = {}
    count = {"evaluations": 0, "sim_steps": 0}

    def score(x):
        f, m, steps, _ = job.score(x)
        count["evaluations"] += x.shape[0]
        count["sim_steps"] += int(steps)
        for i, row in enumerate(x):
            seen[row.tobytes()] = {k: v[i] for k, v in m.items()}
        return f

    out = peer.run(score, job.lower, job.upper, population=s.population, generations=s.generations, f=s.f,
                   cr=s.cr, seed=seed, stop=None if stop is None else (lambda x: stop(x, seen.get(x.tobytes()))))
    return {"best_x": out["best_x"], "fitness": out["fitness"], "evaluations": count["evaluations"],
            "sim_steps": count["sim_steps"], "generations_run": out["generations_run"],
            "stop_reason": out["stop_reason"], "search_wall_s": out["wall_s"]}


def scipy_search(spec: RecoverySpec) -> dict:
    """scipy's DE on the spec's job (its population, generations, F, CR and seed), its
    answer judged like ``timed_search``'s."""
    from app.jobs.recovery.run import set_up

    t = time.perf_counter()
    job = set_up(spec)
    try:
        out = scipy_de(job, spec.search.seed)
        j = judged(job, out["best_x"])
        params = dict(zip(job.names, map(float, out.pop("best_x"))))
    finally:
        job.close()
    return {"fitness": out.pop("fitness")} | j | out | {"time_to_target_s": None, "best_params": params,
                                                        "wall_s": time.perf_counter() - t}


def peer_spec(method: str, lost: tuple[int, ...], seed: int, population: int, generations: int) -> dict:
    """The job spec a peer searches (default model, step, walk and objective; the search
    alone). scipy's DE takes the spec's DE settings (F, CR); CMA-ES is the spec's optimiser."""
    if method not in METHODS:
        raise ValueError(f"unknown peer {method!r}; one of {', '.join(METHODS)}")
    return ONLY_SEARCH | {"damage": {"lost_legs": list(lost)},
                          "search": {"optimizer": "cmaes" if method == "cmaes" else "de", "population": population,
                                     "generations": generations, "seed": seed}}


def run_peer(method: str, lost: tuple[int, ...], seed: int, population: int, generations: int) -> dict:
    """One peer's search at an equal budget, with what it cost and the machine's load."""
    spec = RecoverySpec(**peer_spec(method, lost, seed, population, generations))
    load = os.getloadavg()[0]
    r = (timed_search if method == "cmaes" else scipy_search)(spec)
    return {"method": method, "lost_legs": list(lost), "seed": seed, "population": population,
            "generations": generations, "timestep_s": spec.sim.timestep_s, "walk_s": spec.sim.duration_s,
            "budget_walks": population * (generations + 1)} | r | {
        "load_before": load, "load_after": os.getloadavg()[0], "cores": os.cpu_count()}

"""scipy's ``differential_evolution`` set up as paper 000's DE (app/optim/de.py), the peer
that checks our DE against a well-kept implementation of the same method.

current-to-best/1/bin with our F and CR, our population exactly (an initial population
drawn uniformly in the box from ``seed``, as de.py draws it), a whole generation per call
of ``score`` (``updating="deferred"``, vectorised), ``generations`` generations after the
initial population, no polish and no tolerance stop.

It is a driver, not an ask/tell ``Optimizer`` (app/optim/base.py), and so not in the
registry: scipy's solver runs its own loop and its state mid-search is not a plain dict, so
a job could not checkpoint it and resume bit-identically, which every job must. The
reproductions that compare peers (app/jobs/recovery/reproduce/peers.py, `gaitmend bench
--kind recovery`) call it directly.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from app.optim.base import check_bounds


def run(score: Callable[[np.ndarray], np.ndarray], lower, upper, *, population: int, generations: int,
        f: float, cr: float, seed: int, stop: Callable[[np.ndarray], bool] | None = None) -> dict:
    """Maximise ``score`` (candidates (S, D) -> fitness (S,)) over [lower, upper].
    ``stop(best_x)`` is asked after every generation; True ends the search. Returns the
    best candidate and its fitness, the generations run (the initial population counts
    as one), scipy's stop message and the wall time."""
    from scipy.optimize import differential_evolution

    lower, upper = check_bounds(lower, upper)

    def neg(xt):  # vectorised: scipy hands (D, S)
        return -np.asarray(score(np.ascontiguousarray(np.asarray(xt).T)), dtype=float)

    def callback(intermediate_result) -> bool:  # scipy passes the OptimizeResult to a parameter of this name
        return bool(stop(np.ascontiguousarray(intermediate_result.x)))

    init = lower + np.random.default_rng(seed).random((population, lower.size)) * (upper - lower)
    t0 = time.perf_counter()
    res = differential_evolution(
        neg, list(zip(lower, upper)), strategy="currenttobest1bin", maxiter=generations, mutation=f,
        recombination=cr, rng=seed, polish=False, init=init, tol=0, atol=0, updating="deferred",
        vectorized=True, callback=None if stop is None else callback)
    return {"best_x": np.asarray(res.x), "fitness": float(-res.fun), "generations_run": int(res.nit) + 1,
            "stop_reason": str(res.message), "wall_s": time.perf_counter() - t0}

"""The evidence around a best gait set: held-out planner draws, perturbed physics, and the
one target every case is judged by.

* ``heldout_values``: the search scores every candidate on one fixed sequence of planner
  draws (common random numbers, stream 0), so the best of thousands of candidates is
  partly selected for luck with *those* draws. Re-planning the same gaits with fresh
  draws that took no part in the selection (streams ``HELDOUT_STREAM + i``) gives the
  value a user can expect.
* ``robustness_cases``: the best gaits simulated again with the timestep halved and
  quartered, friction and module masses scaled, then planned with the search's own draws
  (only the physics changes). The gaits of these friction-driven cube modules are chaotic
  (a 1e-3 rad change of the initial joint angles moves a 30 s displacement by ~30 %), so
  this is where a result tuned to the exact numerical model shows itself.
* ``robustness_target``: what a case must reach, in words and as a test (the job's
  summary, its page and the comparison's report all judge through it).

The first two take ``tick(units)``, called after each unit of work (one plan, one gait-set
simulation), which reports progress and raises to stop on cancel.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator

import numpy as np

from app.jobs.evidence import Case, Target, case
from app.jobs.multigait.planner.costs import Evaluation, _root_pose, cost_value, evaluate, planner_draws
from app.jobs.multigait.planner.maps import PlanMap
from app.jobs.multigait.planner.primitives import ModularSim, Primitives
from app.jobs.multigait.planner.rrt import Tree, composed_expander, rrt_mp
from app.robots.modular import PHYSICS, ModulePhysics

HELDOUT_STREAM = 2000  # reuse plans use 1000 + i, the search stream 0
CHUNK = 25  # plans grown together between two cancel checks

Tick = Callable[[int], None]


def _no_tick(n: int) -> None:
    return None


# -- the target ------------------------------------------------------------------------------

COVERAGE_SHARE = 0.8  # of the nominal coverage: a case may lose a fifth of the map
GOAL_MU = 2.0  # the paper's Sec. V-B figure for "reached the goal"


def robustness_target(cost: str, nominal_coverage_pct: float) -> Target:
    """The one target of a multigait answer. A coverage target is relative (coverage depends
    on the map and K, so only the nominal run says what is good), hence its reference."""
    if cost == "coverage":
        ref = nominal_coverage_pct
        return Target(f"coverage at least {COVERAGE_SHARE:.0%} of the nominal {ref:.1f} %",
                      lambda m: m["coverage_pct"] >= COVERAGE_SHARE * ref)
    return Target(f"the tree ends within {GOAL_MU:g} mu of the goal (the paper's Sec. V-B figure)",
                  lambda m: m["goal_distance_mu"] <= GOAL_MU)


# -- held-out plans --------------------------------------------------------------------------

def planned_trees(prims: Primitives, pmap: PlanMap, k: int, iterations: int, seed: int, radius: float,
                  root: np.ndarray, plans: int, stream0: int, tick: Tick = _no_tick) -> Iterator[tuple[slice, Tree]]:
    """``plans`` trees of one gait set's cached primitives, plan ``i`` on its own stream
    ``stream0 + i``, grown ``CHUNK`` at a time: yields (the plans' slice, their trees), then
    ticks."""
    for a in range(0, plans, CHUNK):
        n = min(CHUNK, plans - a)
        p = Primitives(np.repeat(prims.end_xy[:1], n, 0), np.repeat(prims.dyaw[:1], n, 0),
                       np.repeat(prims.path[:1], n, 0))
        draws = np.concatenate([planner_draws(seed, 1, iterations, stream=stream0 + a + i) for i in range(n)])
        yield slice(a, a + n), rrt_mp(pmap, composed_expander(p), k, draws, radius, root_pose=root)
        tick(n)


def heldout_values(sim: ModularSim, gaits: np.ndarray, k: int, pmap: PlanMap, iterations: int, cost: str,
                   seed: int, radius: float, plans: int, prims: Primitives | None = None,
                   tick: Tick = _no_tick) -> np.ndarray:
    """The cost of one gait set ``gaits`` (k * dim,) planned ``plans`` times, each plan with
    its own fresh stream of random points. On flat maps the gaits are simulated once (or
    ``prims`` reused) and composed; otherwise every plan simulates its expansions."""
    out = np.empty(plans)
    g = np.asarray(gaits, dtype=float).reshape(1, -1)
    if pmap.flat:
        if prims is None:
            prims = sim.primitives(g, k)
        for part, tree in planned_trees(prims, pmap, k, iterations, seed, radius, _root_pose(sim), plans,
                                        HELDOUT_STREAM, tick):
            out[part] = cost_value(tree, cost, pmap)
    else:
        for i in range(plans):
            out[i] = evaluate(sim, g, k, pmap, iterations, cost, seed, radius, stream=HELDOUT_STREAM + i).value[0]
            tick(1)
    return out


# -- robustness ------------------------------------------------------------------------------

# the standard cases, with this kind's labels: its "mass" is a module's, its friction both
# the modules' and the floor's
CASES: tuple[Case, ...] = tuple(case(name, label) for name, label in (
    ("dt_half", "timestep halved (5 ms)"),
    ("dt_quarter", "timestep quartered (2.5 ms)"),
    ("friction_0.7", "friction x 0.7 (modules and floor)"),
    ("friction_1.3", "friction x 1.3 (modules and floor)"),
    ("mass_-10pct", "module masses -10 %"),
    ("mass_+10pct", "module masses +10 %"),
))


def physics(c: Case, base: ModulePhysics = PHYSICS) -> ModulePhysics:
    """The modules' physics under case ``c``."""
    return dataclasses.replace(base, timestep=base.timestep * c.timestep_scale,
                               friction=base.friction * c.friction_scale,
                               half_mass=base.half_mass * c.mass_scale)


def metrics_of(ev: Evaluation, pmap: PlanMap) -> dict[str, float]:
    """The first gait set of ``ev``: the tree's coverage and distance to the goal, and the
    mean planar distance one gait moves the robot (flat maps)."""
    out = {"coverage_pct": float(100.0 * ev.tree.coverage()[0]),
           "goal_distance_mu": float(ev.tree.goal_distance(pmap.goal, pmap.flat)[0])}
    if ev.prims is not None:
        out["gait_distance_mu"] = float(ev.prims.distance()[0].mean())
    return out


def gait_metrics(sim: ModularSim, gaits: np.ndarray, k: int, pmap: PlanMap, iterations: int, cost: str, seed: int,
                 radius: float) -> dict[str, float]:
    """One gait set simulated once and planned with the search's draws: ``metrics_of``."""
    ev = evaluate(sim, np.asarray(gaits, dtype=float).reshape(1, -1), k, pmap, iterations, cost, seed, radius)
    return metrics_of(ev, pmap)


def robustness_cases(shape, stuck, pmap: PlanMap, gait_s: float, settle_s: float, gaits: np.ndarray, k: int,
                     iterations: int, cost: str, seed: int, radius: float, cases=CASES,
                     tick: Tick = _no_tick) -> list[dict]:
    """Each case: a fresh simulator with the perturbed physics, the gaits simulated from rest
    and planned with the search's own draws (stream 0)."""
    out = []
    for c in cases:
        sim = ModularSim(shape, stuck, pmap, gait_s, settle_s, physics=physics(c))
        try:
            m = gait_metrics(sim, gaits, k, pmap, iterations, cost, seed, radius)
        finally:
            sim.close()
        out.append({"name": c.name, "label": c.label, "metrics": m})
        tick(1)
    return out

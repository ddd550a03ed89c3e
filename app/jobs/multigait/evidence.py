"""The evidence around a best gait set: held-out planner draws and perturbed physics.

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

Both take ``tick(units)``, called after each unit of work (one plan, one gait-set
simulation), which reports progress and raises to stop on cancel.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from app.jobs.multigait.planner.costs import _root_pose, cost_value, evaluate, planner_draws
from app.jobs.multigait.planner.maps import PlanMap
from app.jobs.multigait.planner.primitives import ModularSim, Primitives
from app.jobs.multigait.planner.rrt import composed_expander, rrt_mp
from app.robots.modular import PHYSICS, ModulePhysics

HELDOUT_STREAM = 2000  # reuse plans use 1000 + i, the search stream 0
CHUNK = 25  # plans grown together between two cancel checks

Tick = Callable[[int], None]


def _no_tick(n: int) -> None:
    return None


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
        for a in range(0, plans, CHUNK):
            n = min(CHUNK, plans - a)
            p = Primitives(np.repeat(prims.end_xy[:1], n, 0), np.repeat(prims.dyaw[:1], n, 0),
                           np.repeat(prims.path[:1], n, 0))
            draws = np.concatenate([planner_draws(seed, 1, iterations, stream=HELDOUT_STREAM + a + i)
                                    for i in range(n)])
            tree = rrt_mp(pmap, composed_expander(p), k, draws, radius, root_pose=_root_pose(sim))
            out[a : a + n] = cost_value(tree, cost, pmap)
            tick(n)
    else:
        for i in range(plans):
            out[i] = evaluate(sim, g, k, pmap, iterations, cost, seed, radius, stream=HELDOUT_STREAM + i).value[0]
            tick(1)
    return out


@dataclasses.dataclass(frozen=True)
class Case:
    name: str
    label: str
    timestep_scale: float = 1.0
    friction_scale: float = 1.0
    mass_scale: float = 1.0

    def physics(self, base: ModulePhysics = PHYSICS) -> ModulePhysics:
        return dataclasses.replace(base, timestep=base.timestep * self.timestep_scale,
                                   friction=base.friction * self.friction_scale,
                                   half_mass=base.half_mass * self.mass_scale)


CASES = (
    Case("dt_half", "timestep halved (5 ms)", timestep_scale=0.5),
    Case("dt_quarter", "timestep quartered (2.5 ms)", timestep_scale=0.25),
    Case("friction_0.7", "friction x 0.7 (modules and floor)", friction_scale=0.7),
    Case("friction_1.3", "friction x 1.3 (modules and floor)", friction_scale=1.3),
    Case("mass_-10pct", "module masses -10 %", mass_scale=0.9),
    Case("mass_+10pct", "module masses +10 %", mass_scale=1.1),
)


def gait_metrics(sim: ModularSim, gaits: np.ndarray, k: int, pmap: PlanMap, iterations: int, cost: str, seed: int,
                 radius: float) -> dict[str, float]:
    """One gait set simulated once and planned with the search's draws: the cost, the
    tree's distance to the goal and the mean planar distance one gait moves the robot."""
    ev = evaluate(sim, np.asarray(gaits, dtype=float).reshape(1, -1), k, pmap, iterations, cost, seed, radius)
    out = {"coverage_pct": float(100.0 * ev.tree.coverage()[0]),
           "goal_distance_mu": float(ev.tree.goal_distance(pmap.goal, pmap.flat)[0])}
    if ev.prims is not None:
        out["gait_distance_mu"] = float(ev.prims.distance()[0].mean())
    return out


def robustness_cases(shape, stuck, pmap: PlanMap, gait_s: float, settle_s: float, gaits: np.ndarray, k: int,
                     iterations: int, cost: str, seed: int, radius: float, cases=CASES,
                     tick: Tick = _no_tick) -> list[dict]:
    """Each case: a fresh simulator with the perturbed physics, the gaits simulated from rest
    and planned with the search's own draws (stream 0)."""
    out = []
    for c in cases:
        sim = ModularSim(shape, stuck, pmap, gait_s, settle_s, physics=c.physics())
        try:
            m = gait_metrics(sim, gaits, k, pmap, iterations, cost, seed, radius)
        finally:
            sim.close()
        out.append({"name": c.name, "label": c.label, "metrics": m})
        tick(1)
    return out

"""Cost functions of multiple gaits (paper 001, Sec. IV-B, Alg. 2) and the checks around them.

``evaluate`` turns B candidate gait sets into B RRT-MP trees and their costs:
  coverage-based: the percentage of map cells the tree reaches (maximised);
  distance-based: the distance (mu) from the tree's nearest node to the goal (minimised;
      the optimiser maximises its negative).
On flat maps the gaits are simulated once (one rollout for all B * k gaits) and composed;
otherwise every expansion is simulated from its parent's state.

The random points of the planner are common random numbers: every tree of a run draws the
same sequence (from the spec's seed), so a candidate's cost is a deterministic function
of its gaits and two candidates are compared on the same planner luck (the paper does not
say how it seeds the planner).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from app.jobs.multigait.planner.maps import PlanMap
from app.jobs.multigait.planner.primitives import ModularSim, Primitives, wrap
from app.jobs.multigait.planner.rrt import Tree, composed_expander, rrt_mp, simulated_expander

COSTS = ("coverage", "distance")


def planner_draws(seed: int, B: int, K: int, stream: int = 0) -> np.ndarray:
    """(B, K, 2) random points in [0, 1)^2, the same sequence for every tree."""
    pts = np.random.default_rng([int(seed), 0x5EED, int(stream)]).random((K, 2))
    return np.broadcast_to(pts, (B, K, 2)).copy()


def cost_value(tree: Tree, cost: str, pmap: PlanMap) -> np.ndarray:
    """The paper's cost per tree: coverage in percent, or distance to the goal in mu."""
    if cost == "coverage":
        return 100.0 * tree.coverage()
    return tree.goal_distance(pmap.goal, planar=pmap.flat)


def fitness_of(value: np.ndarray, cost: str) -> np.ndarray:
    return value if cost == "coverage" else -value


@dataclasses.dataclass
class Evaluation:
    value: np.ndarray  # (B,) coverage % or distance mu
    fitness: np.ndarray  # (B,) maximised
    tree: Tree
    prims: Primitives | None
    sim_s: float
    plan_s: float


def evaluate(sim: ModularSim, gaits: np.ndarray, k: int, pmap: PlanMap, iterations: int, cost: str,
             seed: int, radius: float, record_paths: bool = False, stream: int = 0) -> Evaluation:
    g = np.atleast_2d(gaits)
    B = g.shape[0]
    draws = planner_draws(seed, B, iterations, stream)
    root_pose = _root_pose(sim)
    t0 = time.perf_counter()
    if pmap.flat:
        prims = sim.primitives(g, k)
        t1 = time.perf_counter()
        tree = rrt_mp(pmap, composed_expander(prims), k, draws, radius, root_pose=root_pose,
                      record_paths=record_paths, path_len=prims.path.shape[2])
        t2 = time.perf_counter()
        sim_s, plan_s = t1 - t0, t2 - t1
    else:
        prims = None
        ctrl = sim.controls(g.reshape(B * k, sim.dim)).reshape(B, k, sim.nstep, -1)
        tree = rrt_mp(pmap, simulated_expander(sim, ctrl), k, draws, radius, root_pose=root_pose,
                      root_state=sim.start_state(), record_paths=record_paths, path_len=sim.n_samples)
        sim_s, plan_s = time.perf_counter() - t0, 0.0
    value = cost_value(tree, cost, pmap)
    return Evaluation(value=value, fitness=fitness_of(value, cost), tree=tree, prims=prims, sim_s=sim_s, plan_s=plan_s)


def _root_pose(sim: ModularSim) -> np.ndarray:
    xyz, yaw = sim.pivot_pose(sim.start_state())
    return np.array([xyz[0], xyz[1], xyz[2], yaw])


def verify_tree(sim: ModularSim, gaits: np.ndarray, k: int, tree: dict, max_nodes: int = 60,
                tick=lambda n: None) -> dict:
    """Replay the first ``max_nodes`` nodes of a composed tree in full simulation: each node
    from its parent's *simulated* state (joint angles and velocities carried over), one
    rollout per tree depth, then ``tick(nodes of that depth)`` (progress, cancel). Returns
    per-node planar position and heading errors."""
    n = min(int(len(tree["pos"])), int(max_nodes))
    parent, gait = tree["parent"][:n], tree["gait"][:n]
    depth = np.zeros(n, dtype=int)
    for i in range(1, n):
        depth[i] = depth[parent[i]] + 1
    ctrl = sim.controls(np.atleast_2d(gaits).reshape(k, sim.dim))
    states = np.zeros((n, sim.nstate))
    states[0] = sim.start_state()
    pos = np.zeros((n, 3))
    yaw = np.zeros(n)
    p0, y0 = sim.pivot_pose(states[0])
    pos[0], yaw[0] = p0, y0
    for d in range(1, int(depth.max(initial=0)) + 1):
        idx = np.nonzero(depth == d)[0]
        _, yw, end, _ = sim.rollout(states[parent[idx]], ctrl[gait[idx]])
        states[idx] = end
        p, _ = sim.pivot_pose(end)
        pos[idx] = p
        yaw[idx] = yaw[parent[idx]] + (yw[:, -1] - yw[:, 0])  # unwrapped heading change
        tick(len(idx))
    err = np.linalg.norm(pos[1:, :2] - tree["pos"][1:n, :2], axis=-1)
    yerr = np.abs(wrap(yaw[1:] - tree["yaw"][1:n]))
    gait_len = np.linalg.norm(tree["pos"][1:n, :2] - tree["pos"][parent[1:]][:, :2], axis=-1)
    by_depth = {int(d): float(err[depth[1:] == d].mean()) for d in np.unique(depth[1:])}
    return {
        "nodes": int(n - 1),
        "position_error_mu": {"mean": float(err.mean()) if err.size else 0.0,
                              "max": float(err.max()) if err.size else 0.0,
                              "median": float(np.median(err)) if err.size else 0.0},
        "heading_error_deg": {"mean": float(np.degrees(yerr.mean())) if yerr.size else 0.0,
                              "max": float(np.degrees(yerr.max())) if yerr.size else 0.0},
        "depth1_position_error_mu": float(err[depth[1:] == 1].max()) if np.any(depth[1:] == 1) else 0.0,
        "relative_error_per_edge": float(np.mean(err / np.maximum(depth[1:], 1)) / max(np.mean(gait_len), 1e-9))
        if err.size else 0.0,
        "mean_edge_length_mu": float(gait_len.mean()) if gait_len.size else 0.0,
        "error_by_depth_mu": by_depth,
        "simulated_pos": pos,
        "composed_pos": tree["pos"][:n],
        "depth": depth,
    }

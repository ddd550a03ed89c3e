"""Job kind ``multigait``: k gaits of a modular robot evolved together (paper 001, Alg. 2).

One particle is the concatenation of k Hopf-CPG gaits (Eq. 2, 6 numbers per working
module); its cost is what RRT-MP (Alg. 1) achieves with those gaits: the coverage of the
map or the distance to a goal. PSO (Eq. 1) by default, DE as an option.
"""

from __future__ import annotations

import time

import numpy as np

from app.jobs.base import JobResult, RunContext
from app.jobs.multigait.phases import Budget, controls_block, search_phase
from app.jobs.multigait.spec import MultigaitSpec
from app.optim.registry import make_optimizer
from app.jobs.multigait.planner.costs import cost_value, evaluate, planner_draws, verify_tree
from app.jobs.multigait.evidence import CHUNK, heldout_values, robustness_cases
from app.jobs.multigait.planner.maps import PlanMap, get_map
from app.jobs.multigait.planner.primitives import ModularSim, Primitives
from app.jobs.multigait.planner.rrt import composed_expander, path_to, rrt_mp
from app.robots.modular import MU, get_shape
from app.sim.perturb import robustness_block

RANDOM_SEED_OFFSET = 7919  # the random-search control draws its own stream from the job's seed
ROBUST_COVERAGE_SHARE = 0.8
ROBUST_GOAL_MU = 2.0

# -- problem setup -------------------------------------------------------------------------

def problem_map(spec: MultigaitSpec) -> PlanMap:
    """The spec's map with the goal ``goal_distance_mu`` ahead of the start on flat maps."""
    pmap = get_map(spec.map)
    if not pmap.flat:
        return pmap
    x, y, yaw = pmap.start
    d = spec.planner.goal_distance_mu
    return pmap.with_start_goal(pmap.start, (x + d * np.cos(yaw), y + d * np.sin(yaw), 0.5))


def reuse_scenarios(pmap: PlanMap, distance: float) -> dict[str, PlanMap]:
    """Sec. V-C's three scenarios on a 48 x 27 map: the robot faces +x as in the search;
    1) Empty, goal ahead; 2) Column, goal ahead behind the column; 3) Column, goal behind
    the robot. The paper starts at the map centre, but a goal 30 mu from the centre would
    lie outside a 48 mu map, so start and goal sit symmetrically about the centre."""
    cx, cy = 0.5 * pmap.width, 0.5 * pmap.height
    a, b = (cx - distance / 2, cy, 0.0), (cx + distance / 2, cy, 0.5)
    return {
        "empty_same": get_map("empty").with_start_goal(a, b),
        "column_same": get_map("column").with_start_goal(a, b),
        "column_opposite": get_map("column").with_start_goal((b[0], b[1], 0.0), (a[0], a[1], 0.5)),
    }


def reuse_experiment(prims: Primitives, scenarios: dict[str, PlanMap], plans: int, iterations: int, seed: int,
                     radius: float, root_z: float, tick=lambda n: None) -> dict:
    """Plan ``plans`` times per scenario with the cached primitives of one gait set (each
    plan its own random stream); distance to the goal and coverage, mean / std. Plans grow
    in chunks of ``CHUNK`` trees, with ``tick(plans in the chunk)`` after each."""
    out = {}
    for name, pm in scenarios.items():
        root = np.array([pm.start[0], pm.start[1], root_z, pm.start[2]])
        dist, cov = np.empty(plans), np.empty(plans)
        for a in range(0, plans, CHUNK):
            n = min(CHUNK, plans - a)
            p = Primitives(np.repeat(prims.end_xy, n, 0), np.repeat(prims.dyaw, n, 0), np.repeat(prims.path, n, 0))
            draws = np.concatenate([planner_draws(seed, 1, iterations, stream=1000 + a + i) for i in range(n)])
            tree = rrt_mp(pm, composed_expander(p), prims.k, draws, radius, root_pose=root)
            dist[a : a + n] = cost_value(tree, "distance", pm)
            cov[a : a + n] = cost_value(tree, "coverage", pm)
            tick(n)
        out[name] = {"distance_mu": {"mean": float(dist.mean()), "std": float(dist.std())},
                     "coverage_pct": {"mean": float(cov.mean()), "std": float(cov.std())},
                     "start": list(pm.start), "goal": list(pm.goal[:2])}
    return out


def gait_trace(sim: ModularSim, gait: np.ndarray, state: np.ndarray) -> dict[str, np.ndarray]:
    """Per-step record of one gait from ``state``: for plots, CSVs and replay."""
    xyz, yaw, _, full = sim.rollout(state[None], sim.controls(gait[None]), full=True)
    q = full[0, :, sim.qoff : sim.qoff + sim.model.nq]
    piv, hd = sim.pivot_pose(full[0])
    return {"time_s": (np.arange(q.shape[0]) + 1) * sim.dt, "pivot_mu": piv, "com_m": piv * MU,
            "heading_deg": np.degrees(np.unwrap(hd)), "qpos": q, "ctrl": sim.controls(gait[None])[0]}


def plan_trace(sim: ModularSim, gaits: np.ndarray, k: int, tree: dict, node: int,
               max_gaits: int = 8) -> dict[str, np.ndarray]:
    """The plan from the root to ``node`` executed in full simulation, gait after gait (its
    first ``max_gaits`` gaits: the trace is replayed in 3D at real time)."""
    path = path_to(tree, node)[: max_gaits + 1]
    ctrl = sim.controls(gaits.reshape(k, sim.dim))
    state = sim.start_state()
    qs, piv, hd, gait_id = [], [], [], []
    for n in path[1:]:
        j = int(tree["gait"][n])
        _, _, end, full = sim.rollout(state[None], ctrl[j][None], full=True)
        qs.append(full[0, :, sim.qoff : sim.qoff + sim.model.nq])
        p, h = sim.pivot_pose(full[0])
        piv.append(p)
        hd.append(h)
        gait_id.append(np.full(full.shape[1], j))
        state = end[0]
    if not qs:
        p, h = sim.pivot_pose(state)
        return {"time_s": np.zeros(1), "pivot_mu": p[None], "com_m": p[None] * MU, "heading_deg": np.degrees([h]),
                "qpos": state[None, sim.qoff : sim.qoff + sim.model.nq], "gait": np.zeros(1, dtype=int)}
    q = np.concatenate(qs)
    pv = np.concatenate(piv)
    return {"time_s": (np.arange(q.shape[0]) + 1) * sim.dt, "pivot_mu": pv, "com_m": pv * MU,
            "heading_deg": np.degrees(np.unwrap(np.concatenate(hd))), "qpos": q, "gait": np.concatenate(gait_id),
            "plan_nodes_mu": tree["pos"][path]}


# -- the job ---------------------------------------------------------------------------------

def run(spec: MultigaitSpec, ctx: RunContext) -> JobResult:
    shape = get_shape(spec.robot)
    stuck = tuple(spec.damage.stuck_modules)
    pmap = problem_map(spec)
    k, K = spec.k, spec.iterations
    radius = shape.radius_mu()
    s = spec.search
    coeffs = s.pso_coefficients()
    budget = Budget(ctx, spec.budget_parts())
    sim = ModularSim(shape, stuck, pmap, spec.gait_duration_s, spec.settle_s)
    try:
        lower, upper = sim.bounds(k)
        ckpt = ctx.load_checkpoint() or {}
        steps0 = sim.sim_steps
        opt = make_optimizer(s.optimizer, lower, upper, s.particles, s.seed, cr=s.cr, f=s.f, **coeffs)
        search = search_phase("search", opt, sim, spec, pmap, k, K, radius, budget, ctx, ckpt)
        control = None
        if spec.controls.random_search:
            rs = make_optimizer("random", lower, upper, s.particles, s.seed + RANDOM_SEED_OFFSET)
            control = search_phase("random_search", rs, sim, spec, pmap, k, K, radius, budget, ctx, ckpt,
                                   generations=search["generations_run"] - 1)
        # steps of phases restored from a checkpoint count as if this process had simulated them
        sim.sim_steps = steps0 + search["sim_steps"] + (control["sim_steps"] if control else 0)
        history = search["history"]
        sign = 1.0 if spec.cost == "coverage" else -1.0

        # -- the best gait set, examined ----------------------------------------------------
        t_an = time.perf_counter()
        budget.begin("examine")
        best_x = search["best_x"]
        best_f = sign * search["best_value"]
        ev = evaluate(sim, best_x[None], k, pmap, K, spec.cost, spec.seed, radius, record_paths=True)
        tree = ev.tree.single(0)
        value = float(ev.value[0])
        gaits = best_x.reshape(k, sim.dim)
        state0 = sim.place(sim.state0, 0.0, 0.0, 0.0)
        traces = {f"gait{j + 1}": gait_trace(sim, gaits[j], state0) for j in range(k)}
        goal_node = int(np.argmin(np.linalg.norm((tree["pos"] - np.asarray(pmap.goal))[:, : 2 if pmap.flat else 3],
                                                 axis=1)))
        if spec.cost == "coverage" and pmap.flat:  # show the longest branch
            depth = np.array([len(path_to(tree, i)) for i in range(len(tree["pos"]))])
            goal_node = int(np.argmax(depth))
        traces["plan"] = plan_trace(sim, best_x, k, tree, goal_node)
        per_gait = []
        for j in range(k):
            tr = traces[f"gait{j + 1}"]
            d = tr["pivot_mu"][-1, :2] - tr["pivot_mu"][0, :2]
            per_gait.append({"gait": j + 1, "distance_mu": float(np.hypot(*d)),
                             "rotation_deg": float(tr["heading_deg"][-1] - tr["heading_deg"][0]),
                             "end_mu": d.tolist()})
        budget.tick(1)

        # -- controls: held-out planner draws, the random search's best the same way ---------
        budget.begin("heldout")
        n_ho = spec.controls.heldout_plans
        held = heldout_values(sim, best_x, k, pmap, K, spec.cost, spec.seed, radius, n_ho, prims=ev.prims,
                              tick=budget.tick)
        control_held = None
        if control is not None:
            control_held = heldout_values(sim, control["best_x"], k, pmap, K, spec.cost, spec.seed, radius, n_ho,
                                          tick=budget.tick)

        # -- the composition check and the reuse experiment (flat maps) ----------------------
        if pmap.flat:
            budget.begin("verify")
            verification = (verify_tree(sim, best_x, k, tree, spec.verify.nodes, tick=budget.tick)
                            if spec.verify.nodes > 0 else None)
            composition = None
            if verification is not None:
                composition = {key: verification[key] for key in
                               ("nodes", "position_error_mu", "heading_error_deg", "depth1_position_error_mu",
                                "relative_error_per_edge", "mean_edge_length_mu", "error_by_depth_mu")}
                traces["composition"] = {"time_s": np.arange(len(verification["depth"])) * 1.0,
                                         "depth": verification["depth"],
                                         "composed_mu": verification["composed_pos"],
                                         "simulated_mu": verification["simulated_pos"]}
            reuse = None
            if spec.reuse.enabled:
                budget.begin("reuse")
                reuse = reuse_experiment(ev.prims, reuse_scenarios(pmap, spec.reuse.distance_mu), spec.reuse.plans,
                                         spec.reuse.iterations, spec.seed, radius, root_z=float(tree["pos"][0, 2]),
                                         tick=budget.tick)
        else:
            composition = {"note": "expansions simulated from the parent's full state (non-flat map); nothing composed"}
            reuse = None

        # -- robustness: the best gaits under perturbed physics -----------------------------
        nominal = {"coverage_pct": float(100.0 * ev.tree.coverage()[0]),
                   "goal_distance_mu": float(ev.tree.goal_distance(pmap.goal, pmap.flat)[0])}
        if ev.prims is not None:
            nominal["gait_distance_mu"] = float(ev.prims.distance()[0].mean())
        robustness = None
        if spec.robustness.enabled:
            budget.begin("robustness")
            cases = robustness_cases(shape, stuck, pmap, spec.gait_duration_s, spec.settle_s, best_x, k, K,
                                     spec.cost, spec.seed, radius, tick=budget.tick)
            target, met = robustness_target(spec.cost, nominal)
            for c in cases:
                c["target_met"] = met(c["metrics"])
            robustness = robustness_block(target, nominal, cases)
        analysis_s = time.perf_counter() - t_an
    finally:
        sim.close()
    budget.finish()
    search_wall = search["wall_s"]
    wall = search_wall + (control["wall_s"] if control else 0.0) + analysis_s
    first = history[0] if history else {}
    gens = len(history)
    evaluations = search["evaluations"]
    summary = {
        "kind": "multigait",
        "robot": spec.robot,
        "shape": shape.describe(),
        "damage": spec.damage.model_dump(),
        "seed": spec.seed,
        "cost": spec.cost,
        "cost_units": "percent of map cells holding a tree node" if spec.cost == "coverage" else "mu from the tree to the goal",
        "map": pmap.describe(),
        "gaits": k,
        "iterations": K,
        "search": {"optimizer": s.optimizer, **({"pso": s.pso, **coeffs} if s.optimizer == "pso" else {}),
                   "stop_reason": search["stop_reason"], "generations_run": search["generations_run"]},
        "result": {"final_best": value, "heldout_mean": float(held.mean()), "heldout_std": float(held.std()),
                   "initial_best": first.get("generation_best"),
                   "initial_mean": first.get("mean"), "final_mean": history[-1]["mean"] if history else None,
                   "best_fitness": best_f, "reproduced": bool(abs(sign * value - best_f) < 1e-9),
                   "tree_nodes": int(len(tree["pos"])), "goal_distance_mu": float(ev.tree.goal_distance(pmap.goal, pmap.flat)[0])},
        "controls": controls_block(spec, search, held, control, control_held),
        "robustness": robustness,
        "per_gait": per_gait,
        "best_params": {"names": [f"g{j + 1}_{n}" for j in range(k) for n in _names(sim)], "values": best_x.tolist()},
        "bounds": {"lower": lower.tolist(), "upper": upper.tolist()},
        "tree": {"pos_mu": tree["pos"].tolist(), "yaw": tree["yaw"].tolist(), "parent": tree["parent"].tolist(),
                 "gait": tree["gait"].tolist(), "plan_node": goal_node},
        "composition": composition,
        "reuse": reuse,
        "history": history,
        "control_history": ([{key: r[key] for key in ("generation", "best", "mean", "evaluations")}
                             for r in control["history"]] if control else None),
        "budget": {"formula": spec.budget_formula, "planned": spec.budget_parts(), "used": dict(budget.used),
                   "total": spec.evaluations_budget},
        "timing": {"wall_s": wall, "evaluations": sum(budget.used.values()), "search_evaluations": evaluations,
                   "sim_steps": sim.sim_steps, "sim_steps_per_s": sim.sim_steps / max(wall, 1e-9),
                   "search_s": search_wall, "random_search_s": control["wall_s"] if control else 0.0,
                   "analysis_s": analysis_s, "rollout_s": search["sim_s"], "planner_s": search["plan_s"],
                   "per_generation_s": search_wall / max(gens, 1),
                   "planner_per_tree_s": search["plan_s"] / max(evaluations, 1)},
    }
    # the recorded swept paths are drawn by the plots; they ride along in the traces
    traces["tree"] = {"time_s": np.arange(len(tree["pos"])) * 1.0, "pos_mu": tree["pos"], "parent": tree["parent"],
                      "gait": tree["gait"], "paths_mu": tree["paths"]}
    return JobResult(summary=summary, history=history, traces=traces, model_xml=sim.spec.to_xml(),
                     evaluations=summary["timing"]["evaluations"], sim_steps=sim.sim_steps)


def robustness_target(cost: str, nominal: dict):
    """The target checked under each perturbation, in words and as a test."""
    if cost == "coverage":
        ref = nominal["coverage_pct"]
        return (f"coverage at least {ROBUST_COVERAGE_SHARE:.0%} of the nominal {ref:.1f} %",
                lambda m: bool(m["coverage_pct"] >= ROBUST_COVERAGE_SHARE * ref))
    return (f"the tree ends within {ROBUST_GOAL_MU:g} mu of the goal (the paper's Sec. V-B figure)",
            lambda m: bool(m["goal_distance_mu"] <= ROBUST_GOAL_MU))


def _names(sim: ModularSim) -> list[str]:
    from app.jobs.multigait.cpg import param_names

    return param_names(sim.joints)

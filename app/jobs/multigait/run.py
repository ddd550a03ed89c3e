"""Job kind ``multigait``: k gaits of a modular robot evolved together (paper 001, Alg. 2).

One particle is the concatenation of k Hopf-CPG gaits (Eq. 2, 6 numbers per working
module); its cost is what RRT-MP (Alg. 1) achieves with those gaits: the coverage of the
map or the distance to a goal. PSO (Eq. 1) by default, DE as an option.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from app.jobs.base import JobResult, RunContext
from app.jobs.evidence import Phases, Robustness, control_seed
from app.jobs.multigait.evidence import (heldout_values, metrics_of, planned_trees, robustness_cases,
                                         robustness_target)
from app.jobs.multigait.phases import Job, SearchResult, controls_block, search_phase
from app.jobs.multigait.planner.costs import Evaluation, cost_value, evaluate, verify_tree
from app.jobs.multigait.planner.maps import PlanMap, get_map
from app.jobs.multigait.planner.primitives import ModularSim, Primitives
from app.jobs.multigait.planner.rrt import path_to
from app.jobs.multigait.spec import MultigaitSpec
from app.optim.registry import make_optimizer
from app.robots.modular import MU, get_shape

REUSE_STREAM = 1000  # reuse plan i draws stream 1000 + i (held-out plans 2000 + i, the search 0)

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
    in chunks, with ``tick(plans in the chunk)`` after each."""
    out = {}
    for name, pm in scenarios.items():
        root = np.array([pm.start[0], pm.start[1], root_z, pm.start[2]])
        dist, cov = np.empty(plans), np.empty(plans)
        for part, tree in planned_trees(prims, pm, prims.k, iterations, seed, radius, root, plans, REUSE_STREAM, tick):
            dist[part] = cost_value(tree, "distance", pm)
            cov[part] = cost_value(tree, "coverage", pm)
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


# -- the job: set-up, search, then the analysis of its best, then the summary ---------------

@dataclasses.dataclass
class Searches:
    """The search and its random-search control at the same budget (None when switched off)."""

    search: SearchResult
    control: SearchResult | None


@dataclasses.dataclass
class Best:
    """The best gait set, examined: planned again with its swept paths, each gait traced."""

    x: np.ndarray
    ev: Evaluation
    tree: dict
    plan_node: int
    traces: dict[str, dict]
    per_gait: list[dict]
    nominal: dict[str, float]  # the metrics every robustness case is compared with

    @property
    def value(self) -> float:
        return float(self.ev.value[0])


@dataclasses.dataclass
class Analysis:
    """What the steps after the search found."""

    best: Best
    held: np.ndarray  # the best's cost on held-out planner draws
    controls: list[dict]
    composition: dict | None
    composition_trace: dict | None
    reuse: dict | None
    robustness: dict | None
    seconds: float


def run(spec: MultigaitSpec, ctx: RunContext) -> JobResult:
    job = set_up(spec, ctx)
    try:
        found = search(job)
        analysis = analyse(job, found)
    finally:
        job.sim.close()
    job.phases.finish()
    return summarize(job, found, analysis)


def set_up(spec: MultigaitSpec, ctx: RunContext) -> Job:
    shape = get_shape(spec.robot)
    pmap = problem_map(spec)
    phases = Phases(ctx, spec.budget_parts())
    sim = ModularSim(shape, tuple(spec.damage.stuck_modules), pmap, spec.gait_duration_s, spec.settle_s)
    try:
        lower, upper = sim.bounds(spec.k)
    except BaseException:
        sim.close()
        raise
    return Job(spec, shape, pmap, sim, lower, upper, phases)


def search(job: Job) -> Searches:
    s, sim = job.spec.search, job.sim
    steps0 = sim.sim_steps
    opt = make_optimizer(s.optimizer, job.lower, job.upper, s.particles, s.seed, cr=s.cr, f=s.f,
                         **s.pso_coefficients())
    found = search_phase(job, "search", opt)
    control = None
    if job.spec.controls.random_search:
        rs = make_optimizer("random", job.lower, job.upper, s.particles, control_seed(s.seed))
        control = search_phase(job, "random_search", rs, generations=found.generations_run - 1)
    # steps of phases restored from a checkpoint count as if this process had simulated them
    sim.sim_steps = steps0 + found.sim_steps + (control.sim_steps if control else 0)
    return Searches(found, control)


def analyse(job: Job, found: Searches) -> Analysis:
    t = time.perf_counter()
    best = examine(job, found.search)
    held, rows = controls(job, found, best)
    composition, trace, reuse = paper_checks(job, best)
    rob = robustness(job, best)
    return Analysis(best, held, rows, composition, trace, reuse, rob, time.perf_counter() - t)


def examine(job: Job, search: SearchResult) -> Best:
    """The best gait set planned again (recording the swept paths), each gait and the plan
    traced in full simulation."""
    spec, sim, pmap, k = job.spec, job.sim, job.pmap, job.k
    x = search.best_x
    ev = evaluate(sim, x[None], k, pmap, job.K, spec.cost, spec.seed, job.radius, record_paths=True)
    tree = ev.tree.single(0)
    gaits = x.reshape(k, sim.dim)
    state0 = sim.place(sim.state0, 0.0, 0.0, 0.0)
    traces = {f"gait{j + 1}": gait_trace(sim, gaits[j], state0) for j in range(k)}
    node = plan_node(tree, pmap, spec.cost)
    traces["plan"] = plan_trace(sim, x, k, tree, node)
    job.phase("examine").tick(1)
    return Best(x, ev, tree, node, traces, per_gait(traces, k), metrics_of(ev, pmap))


def plan_node(tree: dict, pmap: PlanMap, cost: str) -> int:
    """The node the shown plan leads to: the one nearest the goal, or, for coverage on a flat
    map (no goal to reach), the end of the longest branch."""
    if cost == "coverage" and pmap.flat:
        depth = np.array([len(path_to(tree, i)) for i in range(len(tree["pos"]))])
        return int(np.argmax(depth))
    d = (tree["pos"] - np.asarray(pmap.goal))[:, : 2 if pmap.flat else 3]
    return int(np.argmin(np.linalg.norm(d, axis=1)))


def per_gait(traces: dict[str, dict], k: int) -> list[dict]:
    """One execution of each gait: planar distance, rotation and end point (Fig. 7)."""
    out = []
    for j in range(k):
        tr = traces[f"gait{j + 1}"]
        d = tr["pivot_mu"][-1, :2] - tr["pivot_mu"][0, :2]
        out.append({"gait": j + 1, "distance_mu": float(np.hypot(*d)),
                    "rotation_deg": float(tr["heading_deg"][-1] - tr["heading_deg"][0]), "end_mu": d.tolist()})
    return out


def controls(job: Job, found: Searches, best: Best) -> tuple[np.ndarray, list[dict]]:
    """The best planned on held-out draws, the random search's best the same way; the
    controls block."""
    spec, tick = job.spec, job.phase("heldout").tick
    n = spec.controls.heldout_plans
    args = (job.k, job.pmap, job.K, spec.cost, spec.seed, job.radius, n)
    held = heldout_values(job.sim, best.x, *args, prims=best.ev.prims, tick=tick)
    control_held = None
    if found.control is not None:
        control_held = heldout_values(job.sim, found.control.best_x, *args, tick=tick)
    return held, controls_block(spec, found.search, held, found.control, control_held)


COMPOSITION_KEYS = ("nodes", "position_error_mu", "heading_error_deg", "depth1_position_error_mu",
                    "relative_error_per_edge", "mean_edge_length_mu", "error_by_depth_mu")
NOT_COMPOSED = {"note": "expansions simulated from the parent's full state (non-flat map); nothing composed"}


def paper_checks(job: Job, best: Best) -> tuple[dict | None, dict | None, dict | None]:
    """Sec. V's checks, flat maps only (elsewhere nothing is composed and the reuse maps are
    flat): composed tree nodes replayed in full simulation, and the gaits reused on new maps
    (Tables III-IV). Returns (composition, its trace, reuse)."""
    spec = job.spec
    if not job.pmap.flat:
        return dict(NOT_COMPOSED), None, None
    composition = trace = reuse = None
    if spec.verify.nodes > 0:
        v = verify_tree(job.sim, best.x, job.k, best.tree, spec.verify.nodes, tick=job.phase("verify").tick)
        composition = {key: v[key] for key in COMPOSITION_KEYS}
        trace = {"time_s": np.arange(len(v["depth"])) * 1.0, "depth": v["depth"],
                 "composed_mu": v["composed_pos"], "simulated_mu": v["simulated_pos"]}
    if spec.reuse.enabled:
        r = spec.reuse
        reuse = reuse_experiment(best.ev.prims, reuse_scenarios(job.pmap, r.distance_mu), r.plans, r.iterations,
                                 spec.seed, job.radius, root_z=float(best.tree["pos"][0, 2]),
                                 tick=job.phase("reuse").tick)
    return composition, trace, reuse


def robustness(job: Job, best: Best) -> dict | None:
    """The best gaits re-simulated under each case, judged by the kind's target."""
    spec = job.spec
    if not spec.robustness.enabled:
        return None
    cases = robustness_cases(job.shape, job.stuck, job.pmap, spec.gait_duration_s, spec.settle_s, best.x, job.k,
                             job.K, spec.cost, spec.seed, job.radius, tick=job.phase("robustness").tick)
    target = robustness_target(spec.cost, best.nominal["coverage_pct"])
    for c in cases:
        c["target_met"] = target.met(c["metrics"])
    return Robustness.build(target.text, best.nominal, cases).to_json()


def summarize(job: Job, found: Searches, a: Analysis) -> JobResult:
    spec, s, sim, best, control = job.spec, job.spec.search, job.sim, a.best, found.control
    used = job.used({"search": found.search.evaluations, "random_search": control.evaluations if control else 0})
    history = with_control(found.search.history, control)
    tree = best.tree
    summary = {
        "kind": "multigait",
        "robot": spec.robot,
        "shape": job.shape.describe(),
        "damage": spec.damage.model_dump(),
        "seed": spec.seed,
        "cost": spec.cost,
        "cost_units": "percent of map cells holding a tree node" if spec.cost == "coverage" else "mu from the tree to the goal",
        "map": job.pmap.describe(),
        "gaits": job.k,
        "iterations": job.K,
        "search": {"optimizer": s.optimizer, **({"pso": s.pso, **s.pso_coefficients()} if s.optimizer == "pso" else {}),
                   "stop_reason": found.search.stop_reason, "generations_run": found.search.generations_run},
        "result": result_block(job, found.search, a),
        "controls": a.controls,
        "robustness": a.robustness,
        "per_gait": best.per_gait,
        "best_params": {"names": [f"g{j + 1}_{n}" for j in range(job.k) for n in _names(sim)],
                        "values": best.x.tolist()},
        "bounds": {"lower": job.lower.tolist(), "upper": job.upper.tolist()},
        "tree": {"pos_mu": tree["pos"].tolist(), "yaw": tree["yaw"].tolist(), "parent": tree["parent"].tolist(),
                 "gait": tree["gait"].tolist(), "plan_node": best.plan_node},
        "composition": a.composition,
        "reuse": a.reuse,
        "history": history,
        "control_history": ([{key: r[key] for key in ("generation", "best", "mean", "evaluations")}
                             for r in control.history] if control else None),
        "budget": {"formula": spec.budget_formula, "planned": spec.budget_parts(), "used": used,
                   "total": spec.evaluations_budget},
        "timing": timing_block(job, found, a, sum(used.values())),
    }
    traces = dict(best.traces)
    if a.composition_trace is not None:
        traces["composition"] = a.composition_trace
    # the recorded swept paths are drawn by the plots; they ride along in the traces
    traces["tree"] = {"time_s": np.arange(len(tree["pos"])) * 1.0, "pos_mu": tree["pos"], "parent": tree["parent"],
                      "gait": tree["gait"], "paths_mu": tree["paths"]}
    return JobResult(summary=summary, history=history, traces=traces, model_xml=sim.spec.to_xml(),
                     evaluations=summary["timing"]["evaluations"], sim_steps=sim.sim_steps)


def with_control(history: list[dict], control: SearchResult | None) -> list[dict]:
    """The search's history with its random-search control's best so far and generation mean
    beside each generation (present.HISTORY_SERIES: the page and the bundle's figure draw both)."""
    by_gen = {r["generation"]: r for r in control.history} if control else {}
    return [r | ({"random_search_best": c["best"], "random_search_mean": c["mean"]}
                 if (c := by_gen.get(r["generation"])) else {}) for r in history]


def result_block(job: Job, search: SearchResult, a: Analysis) -> dict:
    h, best = search.history, a.best
    first = h[0] if h else {}
    best_f = job.sign * search.best_value  # the optimiser's fitness: the cost, signed to be maximised
    return {"final_best": best.value, "heldout_mean": float(a.held.mean()), "heldout_std": float(a.held.std()),
            "initial_best": first.get("generation_best"), "initial_mean": first.get("mean"),
            "final_mean": h[-1]["mean"] if h else None, "best_fitness": best_f,
            "reproduced": bool(abs(job.sign * best.value - best_f) < 1e-9),
            "tree_nodes": int(len(best.tree["pos"])), "goal_distance_mu": best.nominal["goal_distance_mu"]}


def timing_block(job: Job, found: Searches, a: Analysis, evaluations: int) -> dict:
    search, sim = found.search, job.sim
    control_s = found.control.wall_s if found.control else 0.0
    wall = search.wall_s + control_s + a.seconds
    return {"wall_s": wall, "evaluations": evaluations, "search_evaluations": search.evaluations,
            "sim_steps": sim.sim_steps, "sim_steps_per_s": sim.sim_steps / max(wall, 1e-9),
            "search_s": search.wall_s, "random_search_s": control_s, "analysis_s": a.seconds,
            "rollout_s": search.sim_s, "planner_s": search.plan_s,
            "per_generation_s": search.wall_s / max(len(search.history), 1),
            "planner_per_tree_s": search.plan_s / max(search.evaluations, 1)}


def _names(sim: ModularSim) -> list[str]:
    from app.jobs.multigait.cpg import param_names

    return param_names(sim.joints)

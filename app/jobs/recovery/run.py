"""The ``recovery`` job: gait-sequence planning + DE over leg-tip trajectories (paper 000)."""

from __future__ import annotations

import time

import numpy as np

from app.jobs.recovery.sequences import hexapod_neighbours, nominal_tripod, plan_hexapod
from app.jobs.recovery.trajectory import param_names
from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.evidence import Phases
from app.jobs.loop import Generation, run_search
from app.jobs.recovery.spec import RecoverySpec
from app.optim.registry import make_optimizer
from app.robots.catalog import RobotEntry, get_robot
from app.robots.damage import DamageSpec, LockedJoint, WeakJoint
from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
from app.jobs.recovery.metrics import TARGET_TEXT, fitness, meets_target, objective_terms
from app.sim.perturb import case_by_name, robustness_block, walking_cases
from app.jobs.recovery.robust import MultiModelEvaluator, case_models, robust_fitness

# -- problem setup -------------------------------------------------------------------------

def functional_legs(spec: RecoverySpec) -> list[int]:
    return [l for l in range(1, 7) if l not in spec.damage.lost_legs]


def damage_spec(spec: RecoverySpec) -> DamageSpec:
    d = spec.damage
    return DamageSpec(
        lost_legs=tuple(d.lost_legs),
        locked_joints=tuple(LockedJoint(j.leg, j.joint, float(np.radians(j.angle_deg))) for j in d.locked_joints),
        weak_joints=tuple(WeakJoint(j.leg, j.joint, j.torque_scale) for j in d.weak_joints),
    )


def search_bounds(spec: RecoverySpec, robot: RobotEntry) -> tuple[np.ndarray, np.ndarray]:
    """X_min / X_max in the layout of ``param_names``. y0 bounds of legs next to a lost
    leg move outward by ``neighbour_relaxation`` of their width on each side (Sec. III-B)."""
    b = spec.bounds
    legs = functional_legs(spec)
    lost = set(spec.damage.lost_legs)
    relaxed = {n for l in lost for n in hexapod_neighbours(l)} - lost
    y_lo, y_hi = [], []
    for leg in legs:
        lo, hi = b.y0_m.get(str(leg), robot.y0_bounds[leg])
        if leg in relaxed:
            w = (hi - lo) * b.neighbour_relaxation
            lo, hi = lo - w, hi + w
        y_lo.append(lo)
        y_hi.append(hi)
    x_lo, x_hi = b.x0_m or robot.x0_bounds
    sl = b.step_length_m or robot.step_length_bounds
    sh = b.step_height_m or robot.step_height_bounds
    lower = np.array(y_lo + [x_lo] * len(legs) + [sl[0], sh[0]])
    upper = np.array(y_hi + [x_hi] * len(legs) + [sl[1], sh[1]])
    return lower, upper


def nominal_params(robot: RobotEntry, legs: list[int]) -> np.ndarray:
    return np.array([robot.nominal_y0(l) for l in legs] + [robot.nominal_x0()] * len(legs)
                    + [robot.nominal_step_length, robot.nominal_step_height])


def sim_model(spec: RecoverySpec, robot: RobotEntry):
    """The damaged robot's spec and model at the spec's timestep (the bundle's robot.xml
    is the spec, so the timestep is set there, not only in the compiled model)."""
    mspec, _ = robot.model(damage_spec(spec))
    mspec.option.timestep = spec.sim.timestep_s
    return mspec, mspec.compile()


def sim_config(spec: RecoverySpec) -> SimConfig:
    return SimConfig(duration_s=spec.sim.duration_s, settle_s=spec.sim.settle_s, period_s=spec.gait.period_s,
                     stance_height_m=spec.gait.stance_height_m, step_depth_m=spec.gait.step_depth_m)


def _scored(ev: GaitEvaluator, x: np.ndarray, weights, units: str) -> dict:
    r = ev.evaluate(x)
    m = {k: (bool(v[0]) if k == "fell" else float(v[0])) for k, v in r.metrics.items()}
    terms = {k: float(v[0]) for k, v in objective_terms(r.metrics, weights, units).items()}
    return {"metrics": m, "fitness": float(fitness(r.metrics, weights, units)[0]), "terms": terms}


# -- the job ---------------------------------------------------------------------------------

class _Scorer:
    """Fitness of a population on the nominal model, or on several models (robust search).
    Returns (fitness (P,), nominal-model metrics (P,), simulated steps)."""

    def __init__(self, spec: RecoverySpec, robot, mspec, model, seq, cfg):
        self.weights, self.units = spec.objective.weights, spec.objective.units
        self.robust = spec.robust
        self.cases = [case_by_name(walking_cases(robot.geometry.total_mass), n) for n in spec.robust.models] \
            if spec.robust else []
        models = [model] + case_models(mspec, model, self.cases)
        self.ev = MultiModelEvaluator(robot, models, seq, cfg)

    def __call__(self, x: np.ndarray):
        r = self.ev.evaluate_all(x)
        if self.robust is None:
            m = {k: v[:, 0] for k, v in r.metrics.items()}
            return fitness(m, self.weights, self.units), m, r.sim_steps
        f, _ = robust_fitness(r.metrics, self.weights, self.units, self.robust.aggregate)
        return f, {k: v[:, 0] for k, v in r.metrics.items()}, r.sim_steps

    def per_model(self, x: np.ndarray) -> list[dict]:
        r = self.ev.evaluate_all(x)
        _, f = robust_fitness(r.metrics, self.weights, self.units, self.robust.aggregate)
        names = ["nominal"] + [c.name for c in self.cases]
        return [{"name": n, "fitness": float(f[0, k]),
                 "metrics": {key: (bool(v[0, k]) if key == "fell" else float(v[0, k])) for key, v in r.metrics.items()}}
                for k, n in enumerate(names)]

    def close(self):
        self.ev.close()


def run(spec: RecoverySpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    legs = functional_legs(spec)
    com_xy = robot.stance_com_xy(model, spec.gait.stance_height_m)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(), com_xy)
    cfg = sim_config(spec)
    weights, units = spec.objective.weights, spec.objective.units
    lower, upper = search_bounds(spec, robot)
    names = param_names(legs)
    s = spec.search
    total = s.generations + 1  # generation 0 is the initial population
    names_of_phases = ["search"] + (["random_search"] if spec.controls.random_search else [])

    score = _Scorer(spec, robot, mspec, model, seq, cfg)
    score.ev_models = spec.models_per_candidate
    ev = GaitEvaluator(robot, model, seq, cfg)
    base_ev = GaitEvaluator(robot, model, nominal_tripod(legs), cfg)
    all_cases = walking_cases(robot.geometry.total_mass)
    cases = [case_by_name(all_cases, n) for n in spec.robustness.cases]
    rob_ev = MultiModelEvaluator(robot, case_models(mspec, model, cases), seq, cfg) if cases else None
    try:
        opts = {"search": make_optimizer(s.optimizer, lower, upper, s.population, s.seed, cr=s.cr, f=s.f)}
        if spec.controls.random_search:
            # its own stream of the job's seed, so adding the control leaves the search's draws alone
            opts["random_search"] = make_optimizer("random", lower, upper, s.population, [s.seed, 1])

        def evaluate(x: np.ndarray) -> Generation:
            f, m, steps = score(x)
            return Generation(f, {"fell": int(np.sum(m["fell"]))}, {"sim_steps": steps},
                              evaluations=len(f) * score.ev_models)

        phases = Phases(ctx, {name: total for name in names_of_phases})
        seg_start = time.perf_counter()
        searches = {"search": run_search(opts["search"], evaluate, s.generations, phases.context("search"), spec.stop)}
        if "random_search" in opts:  # as many generations as the search ran, when a stop rule ended it early
            searches["random_search"] = run_search(opts["random_search"], evaluate,
                                                   searches["search"].generations_run - 1,
                                                   phases.context("random_search"))
        post_start = time.perf_counter()

        def enter(name: str) -> None:
            """Between the post-search units of work: stop on cancel (the searches' results are
            in the checkpoint, a resume starts here), and say which one runs."""
            if ctx.is_cancelled():
                raise Cancelled()
            ctx.progress(phases.total, phases.total,
                         {"phase": name, "best": float(searches["search"].best_fitness),
                          "evaluations": int(sum(o.evaluations for o in searches.values()))})

        enter("final_scoring")
        state = {"evaluations": sum(o.evaluations for o in searches.values()),
                 "sim_steps": sum(int(o.totals.get("sim_steps", 0)) for o in searches.values()),
                 "wall_s": sum(o.wall_s for o in searches.values())}

        best_x = searches["search"].best_x
        nominal = nominal_params(robot, legs)
        best = _scored(ev, best_x, weights, units)
        baseline = _scored(base_ev, nominal, weights, units)
        state["evaluations"] += 2
        controls = [{
            "name": "baseline", "label": "nominal tripod with nominal parameters (no recovery)", "evaluations": 1,
            "metrics": baseline["metrics"], "fitness": baseline["fitness"],
            "target_met": meets_target(baseline["metrics"]),
            "note": ("already meets the target without recovery" if meets_target(baseline["metrics"])
                     else "does not meet the target") + ("; falls (chassis or upper leg on the ground)"
                                                        if baseline["metrics"]["fell"] else ""),
        }]
        if "random_search" in opts:
            enter("random_search_scoring")
            rx = searches["random_search"].best_x
            rs = _scored(ev, rx, weights, units)
            state["evaluations"] += 1
            controls.append({
                "name": "random_search", "label": "uniform random search over the same bounds",
                "evaluations": total * s.population * spec.models_per_candidate,
                "metrics": rs["metrics"], "fitness": rs["fitness"], "target_met": meets_target(rs["metrics"]),
                "params": {n: float(v) for n, v in zip(names, rx)},
                "note": "same budget, same scoring" + (" (robust)" if spec.robust else "")
                        + f"; {'beats' if rs['fitness'] > best['fitness'] else 'does not beat'} the search's best F",
            })
        robustness = None
        if rob_ev is not None:
            enter("robustness")
            r = rob_ev.evaluate_all(best_x)
            state["evaluations"] += len(cases)
            state["sim_steps"] += r.sim_steps
            rows = []
            for k, c in enumerate(cases):
                m = {key: (bool(v[0, k]) if key == "fell" else float(v[0, k])) for key, v in r.metrics.items()}
                rows.append({"name": c.name, "label": c.label, "metrics": m, "target_met": meets_target(m),
                             "fitness": float(fitness({key: v[:, k] for key, v in r.metrics.items()}, weights, units)[0])})
            robustness = robustness_block(TARGET_TEXT, best["metrics"], rows)
        robust = None
        if spec.robust is not None:
            robust = spec.robust.model_dump() | {"best_per_model": score.per_model(best_x[None])}
        enter("traces")
        traces = {"best": ev.trace(best_x), "baseline": base_ev.trace(nominal)}
    finally:
        score.close()
        ev.close()
        base_ev.close()
        if rob_ev is not None:
            rob_ev.close()
    wall = state["wall_s"] + time.perf_counter() - post_start  # searches (across resumes) + final scoring
    history = searches["search"].history
    best["params"] = {n: float(v) for n, v in zip(names, best_x)}
    best["target_met"] = meets_target(best["metrics"])
    baseline["params"] = {n: float(v) for n, v in zip(names, nominal)}
    baseline["gait"] = nominal_tripod(legs).as_dict()
    baseline["target_met"] = controls[0]["target_met"]
    evaluations, sim_steps = state["evaluations"], state["sim_steps"]
    summary = {
        "kind": "recovery",
        "robot": spec.robot,
        "damage": spec.damage.model_dump(),
        "seed": spec.seed,
        "baseline": baseline,
        "best": best,
        "target": {"text": TARGET_TEXT, "best_met": best["target_met"], "baseline_met": baseline["target_met"],
                   "note": ("the baseline already meets the target: this damage needs no recovery"
                            if baseline["target_met"] else "")},
        "controls": controls,
        "robustness": robustness,
        "robust": robust,
        "gait": seq.as_dict() | {"period_s": ev.n_period * ev.dt},
        "timestep_s": float(model.opt.timestep),
        "bounds": {"names": names, "lower": lower.tolist(), "upper": upper.tolist()},
        "history": history,
        "random_search_history": searches["random_search"].history if "random_search" in searches else [],
        "search": {"stop_reason": searches["search"].stop_reason, "generations_run": searches["search"].generations_run},
        "timing": {"wall_s": wall, "evaluations": evaluations,
                   "sim_steps_per_s": sim_steps / max(wall, 1e-9), "sim_steps": sim_steps,
                   "setup_s": seg_start - t0},
    }
    return JobResult(summary=summary, history=history, traces=traces, model_xml=mspec.to_xml(),
                     evaluations=evaluations, sim_steps=sim_steps)

"""The ``recovery`` job: gait-sequence planning + DE over leg-tip trajectories (paper 000)."""

from __future__ import annotations

import time

import numpy as np

from app.gaits.sequences import hexapod_neighbours, nominal_tripod, plan_hexapod
from app.gaits.trajectory import param_names
from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.recovery.spec import RecoverySpec
from app.optim.registry import make_optimizer
from app.robots.catalog import RobotEntry, get_robot
from app.robots.damage import DamageSpec, LockedJoint, WeakJoint
from app.sim.evaluate import GaitEvaluator, SimConfig
from app.sim.metrics import fitness, objective_terms

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


def sim_config(spec: RecoverySpec) -> SimConfig:
    return SimConfig(duration_s=spec.sim.duration_s, settle_s=spec.sim.settle_s, period_s=spec.gait.period_s,
                     stance_height_m=spec.gait.stance_height_m, step_depth_m=spec.gait.step_depth_m)


def _scored(ev: GaitEvaluator, x: np.ndarray, weights, units: str) -> dict:
    r = ev.evaluate(x)
    m = {k: (bool(v[0]) if k == "fell" else float(v[0])) for k, v in r.metrics.items()}
    terms = {k: float(v[0]) for k, v in objective_terms(r.metrics, weights, units).items()}
    return {"metrics": m, "fitness": float(fitness(r.metrics, weights, units)[0]), "terms": terms}


# -- the job ---------------------------------------------------------------------------------

def run(spec: RecoverySpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    robot = get_robot(spec.robot)
    mspec, model = robot.model(damage_spec(spec))
    legs = functional_legs(spec)
    com_xy = robot.stance_com_xy(model, spec.gait.stance_height_m)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(), com_xy)
    cfg = sim_config(spec)
    weights, units = spec.objective.weights, spec.objective.units
    lower, upper = search_bounds(spec, robot)
    names = param_names(legs)

    ev = GaitEvaluator(robot, model, seq, cfg)
    base_ev = GaitEvaluator(robot, model, nominal_tripod(legs), cfg)
    try:
        s = spec.search
        opt = make_optimizer(s.optimizer, lower, upper, s.population, s.seed, cr=s.cr, f=s.f)
        history: list[dict] = []
        evaluations = sim_steps = 0
        wall_before = 0.0
        ckpt = ctx.load_checkpoint()
        if ckpt is not None:
            opt.restore(ckpt["optimizer"])
            history, evaluations, sim_steps = ckpt["history"], ckpt["evaluations"], ckpt["sim_steps"]
            wall_before = ckpt["wall_s"]
        total = s.generations + 1  # generation 0 is the initial population
        seg_start = time.perf_counter()
        while opt.generation < total:
            if ctx.is_cancelled():
                raise Cancelled()
            x = opt.ask()
            r = ev.evaluate(x)
            f = fitness(r.metrics, weights, units)
            opt.tell(f)
            evaluations += len(f)
            sim_steps += r.sim_steps
            pop_fit = opt.population_fitness
            row = {"generation": opt.generation - 1, "best": opt.best[1], "mean": float(np.mean(pop_fit)),
                   "worst": float(np.min(pop_fit)), "generation_best": float(np.max(f)),
                   "fell": int(np.sum(r.metrics["fell"])), "evaluations": evaluations}
            history.append(row)
            wall = wall_before + time.perf_counter() - seg_start
            ctx.save_checkpoint({"optimizer": opt.state(), "history": history, "evaluations": evaluations,
                                 "sim_steps": sim_steps, "wall_s": wall})
            ctx.progress(opt.generation, total, {"best": row["best"], "mean": row["mean"], "worst": row["worst"],
                                                 "evaluations": evaluations,
                                                 "sim_steps_per_s": sim_steps / max(wall, 1e-9)})

        best_x, best_f = opt.best
        nominal = nominal_params(robot, legs)
        best = _scored(ev, best_x, weights, units)
        baseline = _scored(base_ev, nominal, weights, units)
        traces = {"best": ev.trace(best_x), "baseline": base_ev.trace(nominal)}
        evaluations += 2
    finally:
        ev.close()
        base_ev.close()
    wall = wall_before + time.perf_counter() - seg_start
    best["params"] = {n: float(v) for n, v in zip(names, best_x)}
    baseline["params"] = {n: float(v) for n, v in zip(names, nominal)}
    baseline["gait"] = nominal_tripod(legs).as_dict()
    summary = {
        "kind": "recovery",
        "robot": spec.robot,
        "damage": spec.damage.model_dump(),
        "seed": spec.seed,
        "baseline": baseline,
        "best": best,
        "gait": seq.as_dict() | {"period_s": ev.n_period * ev.dt},
        "bounds": {"names": names, "lower": lower.tolist(), "upper": upper.tolist()},
        "history": history,
        "timing": {"wall_s": wall, "evaluations": evaluations,
                   "sim_steps_per_s": sim_steps / max(wall, 1e-9), "sim_steps": sim_steps,
                   "setup_s": seg_start - t0},
    }
    return JobResult(summary=summary, history=history, traces=traces, model_xml=mspec.to_xml(),
                     evaluations=evaluations, sim_steps=sim_steps)

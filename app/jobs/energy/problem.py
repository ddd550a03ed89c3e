"""The GA's search space (p_GA = [T, t_i, beta_i, l_i]) and the evaluation of a population.

Encoding. ``trot``: x = [T, links...] (the trot fixes t_i and beta_i given T). ``free``:
x = [T, phase_HR, phase_FL, phase_HL, beta_FR..HL, links...] with phases as fractions of T
(FR touches down at 0: only relative timing matters). Links appear only when
``design.optimise_links``.

A population is evaluated in worker processes (``search.workers``, 0 = every core): the
evaluation is deterministic and independent per candidate, so the numbers do not depend on
the process count; results come back in candidate order.
"""

from __future__ import annotations

import dataclasses
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np

from app.jobs.energy.dynamics.gait import Gait, Task
from app.jobs.energy.dynamics.pipeline import EvalConfig, evaluate
from app.robots.quadruped import QUADRUPED25, QuadrupedGeometry
from app.sim.threads import sim_threads


@dataclasses.dataclass(frozen=True)
class Space:
    family: str
    optimise_links: bool
    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]
    fixed_links: tuple[float, float, float]


def space(spec) -> Space:
    g = spec.gait
    lo, hi, names = [g.period_bounds_s[0]], [g.period_bounds_s[1]], ["T_s"]
    if g.family == "free":
        lo += [0.0] * 3
        hi += [1.0] * 3
        names += ["phase_HR", "phase_FL", "phase_HL"]
        lo += [g.duty_bounds[0]] * 4
        hi += [g.duty_bounds[1]] * 4
        names += ["beta_FR", "beta_HR", "beta_FL", "beta_HL"]
    if spec.design.optimise_links:
        for (a, b), n in zip(spec.design.link_bounds_m, ("l_hip_m", "l_thigh_m", "l_calf_m")):
            lo.append(a)
            hi.append(b)
            names.append(n)
    return Space(family=g.family, optimise_links=spec.design.optimise_links, lower=np.array(lo), upper=np.array(hi),
                 names=tuple(names), fixed_links=tuple(spec.design.links_m))


def decode(sp: Space, x: np.ndarray) -> tuple[Gait, tuple[float, float, float]]:
    T = float(x[0])
    i = 1
    if sp.family == "trot":
        gait = Gait(period=T, touchdown=(0.0, T / 2, T / 2, 0.0), duty=(0.5,) * 4)
    else:
        phases = (0.0, *(float(p) % 1.0 for p in x[1:4]))
        duty = tuple(float(b) for b in x[4:8])
        gait = Gait(period=T, touchdown=tuple(p * T for p in phases), duty=duty)
        i = 8
    links = tuple(float(v) for v in x[i:i + 3]) if sp.optimise_links else sp.fixed_links
    return gait, links


def encode_nominal(sp: Space, spec) -> np.ndarray:
    """Table 1's gait and links in this space (the baseline)."""
    g = spec.gait
    x = [g.period_s]
    if sp.family == "free":
        x += [(t / g.period_s) % 1.0 for t in g.touchdown_s[1:]]
        x += list(g.duty)
    if sp.optimise_links:
        x += list(spec.design.links_m)
    return np.asarray(x, dtype=float)


def geometry(spec, links, **over) -> QuadrupedGeometry:
    return dataclasses.replace(QUADRUPED25, links=tuple(links), inertia=spec.design.inertia,
                               friction=spec.task.friction, **over)


def task_of(spec, **over) -> Task:
    t = spec.task
    args = dict(speed=t.speed_m_s, height=t.height_m, swing_height=t.swing_height_m, friction=t.friction)
    args.update(over)
    return Task(**args)


def eval_config(spec, **over) -> EvalConfig:
    m = spec.model
    args = dict(knots=m.knots, k=m.spline_coefficients, leg_dynamics=m.leg_dynamics,
                residual_iterations=m.residual_iterations, jerk_weight=m.jerk_weight)
    args.update(over)
    return EvalConfig(**args)


def compact(r: dict[str, Any]) -> dict[str, Any]:
    """What the search keeps of one evaluation (JSON-able)."""
    out = {"fitness": float(r["fitness"]), "feasible": bool(r["feasible"]), "failed": r["failed"]}
    if "cot" in r:
        out.update(cot_final=r["cot"]["final"], cot_nlp=r["cot"]["nlp"], cot_qp=r["cot"]["qp"],
                   jerk_term=r["jerk_term_N_s"], periodicity_error=r["periodicity_error"],
                   eps_nlp=r["eps"]["nlp"]["norm"], eps_qp=r["eps"]["qp"]["norm"])
    return out


def _evaluate_one(args) -> dict[str, Any]:
    spec_dict, x = args
    from app.jobs.energy.spec import EnergySpec  # noqa: PLC0415 (worker process import)

    spec = EnergySpec.parse(spec_dict)
    sp = space(spec)
    gait, links = decode(sp, np.asarray(x))
    return compact(evaluate(geometry(spec, links), gait, task_of(spec), eval_config(spec)))


class PopulationEvaluator:
    """Evaluates candidate rows in order; a process pool when more than one worker."""

    def __init__(self, spec):
        self.spec = spec
        self.sp = space(spec)
        n = spec.search.workers or sim_threads()
        self.workers = max(1, min(n, spec.search.population))
        self._pool = None
        if self.workers > 1:
            import multiprocessing as mp

            try:
                self._pool = ProcessPoolExecutor(self.workers, mp_context=mp.get_context("spawn"))
            except (OSError, ValueError, AssertionError):  # no child processes allowed here: stay in process
                self._pool = None
                self.workers = 1
        self._spec_dict = spec.model_dump(mode="json")

    def __call__(self, X: np.ndarray) -> list[dict[str, Any]]:
        jobs = [(self._spec_dict, [float(v) for v in x]) for x in X]
        if self._pool is not None:
            try:
                return list(self._pool.map(_evaluate_one, jobs))
            except (AssertionError, BrokenProcessPool, OSError):
                # A daemonic worker process may not have children: evaluate here instead
                # (same numbers, one core).
                self.close()
                self.workers = 1
        return [_evaluate_one(j) for j in jobs]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

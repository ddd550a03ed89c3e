"""Gait candidates scored on several (perturbed) worlds at once.

``MultiModelEvaluator`` runs every candidate on every model: models that share a size
signature and timestep (friction, masses, payload edits) go into one native rollout call,
one model per batch element; a model with another timestep or structure (finer step, rough
floor) gets its own call. Used twice by the recovery job: the robust search (each
candidate's fitness is the mean or the worst over the models) and the robustness block
(the final answer re-simulated under every standard perturbation), and the held-out set
(the answer on random models drawn from the stated ranges, ``held_out``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import mujoco
import numpy as np

from app.jobs.recovery.cases import HELD_OUT_STREAM, RANDOM_RANGES, RANGE_TEXT, draw_models, random_models
from app.jobs.recovery.sequences import GaitSequence
from app.robots.catalog import RobotEntry
from app.jobs.recovery.evaluate import EvalResult, GaitEvaluator, SimConfig
from app.jobs.recovery.metrics import fitness
from app.sim.perturb import Perturbation, perturbed_model, same_signature

AGGREGATES = ("mean", "worst")
# The randomised search's aggregates (app/jobs/recovery/randomised.py): the mean over the
# generation's K random models, or CVaR: the mean of the worst ceil(share x K) of them.
RANDOM_AGGREGATES = ("mean", "cvar")


class MultiModelEvaluator:
    def __init__(self, robot: RobotEntry, models: Sequence[mujoco.MjModel], seq: GaitSequence, cfg: SimConfig):
        self.models = list(models)
        groups: list[list[int]] = []
        for i, m in enumerate(self.models):
            for g in groups:
                if same_signature(self.models[g[0]], m):
                    g.append(i)
                    break
            else:
                groups.append([i])
        self.groups = groups
        self.evaluators = [GaitEvaluator(robot, self.models[g[0]], seq, cfg, variants=[self.models[i] for i in g])
                           for g in groups]

    def evaluate_all(self, params: np.ndarray) -> EvalResult:
        """Metrics (P, K) in the order of ``models``."""
        params = np.atleast_2d(params)
        out: dict[str, np.ndarray] = {}
        steps = 0
        for g, ev in zip(self.groups, self.evaluators):
            r = ev.evaluate_all(params)
            steps += r.sim_steps
            for k, v in r.metrics.items():
                if k not in out:
                    out[k] = np.empty((params.shape[0], len(self.models)), dtype=v.dtype)
                out[k][:, g] = v
        return EvalResult(metrics=out, sim_steps=steps)

    def close(self) -> None:
        for ev in self.evaluators:
            ev.close()


def aggregate(f: np.ndarray, how: str) -> np.ndarray:
    """(P, K) fitness over models -> (P,)."""
    if how == "mean":
        return f.mean(axis=1)
    if how == "worst":
        return f.min(axis=1)
    raise ValueError(f"aggregate must be one of {AGGREGATES}, got {how!r}")


def cvar(f: np.ndarray, share: float) -> np.ndarray:
    """(P, K) fitness over models -> (P,): the mean of each row's worst ceil(share x K)
    values (share 1: the mean; share <= 1/K: the worst)."""
    k = max(1, min(f.shape[1], int(np.ceil(share * f.shape[1] - 1e-9))))
    return np.sort(f, axis=1)[:, :k].mean(axis=1)


def robust_fitness(metrics: dict[str, np.ndarray], weights, units: str, how: str) -> tuple[np.ndarray, np.ndarray]:
    """(aggregated (P,), per model (P, K)) Eq. 5 fitness."""
    P, K = metrics["fell"].shape
    flat = {k: v.reshape(-1) for k, v in metrics.items()}
    f = fitness(flat, weights, units).reshape(P, K)
    return aggregate(f, how), f


def case_models(mspec: mujoco.MjSpec, model: mujoco.MjModel, cases: Sequence[Perturbation]) -> list[mujoco.MjModel]:
    return [perturbed_model(mspec, c, model) for c in cases]


def held_out_walks(mspec: mujoco.MjSpec, robot: RobotEntry, seq: GaitSequence, cfg: SimConfig, x: np.ndarray,
                   seed: int, n: int):
    """Gaits ``x`` (D,) or (P, D) on the ``n`` held-out random models of ``seed`` (the
    held-out stream), in one rollout call: (the draws, the rollout's result: metrics (P, n))."""
    draws = draw_models(seed, n, HELD_OUT_STREAM)
    ev = MultiModelEvaluator(robot, random_models(mspec, draws, robot.geometry.total_mass), seq, cfg)
    try:
        return draws, ev.evaluate_all(np.atleast_2d(x))
    finally:
        ev.close()


def held_out(mspec: mujoco.MjSpec, robot: RobotEntry, seq: GaitSequence, cfg: SimConfig, x: np.ndarray, seed: int,
             n: int, judge: Callable[[dict], bool | None]) -> tuple[dict, int]:
    """The answer ``x`` on ``n`` random models drawn from ``cases.RANDOM_RANGES`` with the
    held-out stream of the job's seed (never drawn by a search), in one rollout call:
    ({"n", "met", "share", "ranges", "models": [{"draw", "metrics", "target_met"}]}, steps)."""
    draws, r = held_out_walks(mspec, robot, seq, cfg, x, seed, n)
    models = []
    for k, d in enumerate(draws):
        m = {key: (bool(v[0, k]) if key == "fell" else float(v[0, k])) for key, v in r.metrics.items()}
        models.append({"draw": d, "metrics": m, "target_met": judge(m)})
    met = sum(1 for m in models if m["target_met"] is True)
    return {"n": n, "met": met, "share": met / n if n else None, "ranges": dict(RANDOM_RANGES),
            "ranges_text": RANGE_TEXT, "stream": "held-out stream of the job's seed (cases.HELD_OUT_STREAM)",
            "models": models}, r.sim_steps

"""Randomised robust search (issue 24, spec section ``randomised``): each generation draws K
random models from the stated ranges (app/sim/perturb.py ``RANDOM_RANGES``) and scores every candidate
on all K in one batched rollout; its fitness is the mean of the Eq. 5 fitness over the K
models, or their CVaR (the mean of the worst ``cvar_share``).

The draw: ``perturb.draw_models(seed, K, SEARCH_STREAM, generation)``, a stream of the job's
seed that neither the search's own draws nor the held-out set use, indexed by the
generation (the optimizer's, restored from a checkpoint), so a resumed search draws the
same models and continues bit-identically.

DE's one-to-one selection (Eq. 10) compares a trial with its parent. Under a new draw the
parent's old fitness is of other models, so every generation the parents are scored again
on the generation's draw, in the same rollout call as the trials, and the selection
compares the two on the same K models. Those re-scorings are simulations and count: a
generation after the first costs 2 x P x K walks, the initial one P x K, so the search
costs P x K x (2G + 1) walks (``RecoverySpec.search_walks``). The answer is the best of the
final population on the last generation's draw.
"""

from __future__ import annotations

import mujoco
import numpy as np

from app.jobs.loop import Generation
from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
from app.jobs.recovery.metrics import fitness
from app.jobs.recovery.robust import cvar
from app.jobs.recovery.sequences import GaitSequence
from app.optim.de import DifferentialEvolution
from app.robots.catalog import RobotEntry
from app.sim.perturb import (RANDOM_RANGES, RANGE_TEXT, SEARCH_STREAM, draw_models, random_model, random_world,
                              same_signature)

PARENTS_TEXT = ("DE's parents are scored again on every generation's draw, in the same rollout as the trials, so "
                "the selection compares a trial and its parent on the same models; those walks count in the budget")


def draws_of(seed: int, k: int, generation: int) -> list[dict[str, float]]:
    """The K random models of a generation of the job with this seed."""
    return draw_models(seed, k, SEARCH_STREAM, generation)


class RandomisedScorer:
    """A population's fitness on the generation's K random models (see the module's text).
    The run's ``_Scorer`` interface where the search needs it: ``redrawn`` is the search's
    evaluation, ``metrics_of`` has no nominal-model walk at hand (the goal re-runs one)."""

    def __init__(self, spec, robot: RobotEntry, mspec: mujoco.MjSpec, seq: GaitSequence, cfg: SimConfig):
        r = spec.randomised
        self.k, self.how, self.share, self.seed = r.models, r.aggregate, r.cvar_share, spec.seed
        self.weights, self.units = spec.objective.weights, spec.objective.units
        self.mass = robot.geometry.total_mass
        self.world = random_world(mspec)
        models = self._models(0)
        self.ev = GaitEvaluator(robot, models[0], seq, cfg, variants=models)
        self.models_per_candidate = self.k
        self.last: dict | None = None  # the last generation's draw, candidates and per-model fitness

    def _models(self, generation: int) -> list[mujoco.MjModel]:
        return [random_model(self.world, d, self.mass) for d in draws_of(self.seed, self.k, generation)]

    def score(self, x: np.ndarray, generation: int) -> tuple[np.ndarray, np.ndarray, dict, int]:
        """(aggregate (P,), per model (P, K), metrics (P, K), steps) on the generation's draw."""
        models = self._models(generation)
        if not all(same_signature(m, self.ev.model) for m in models):
            raise ValueError("random models must share one size signature (one rollout call)")
        self.ev.variants = models
        r = self.ev.evaluate_all(np.atleast_2d(x))
        P = r.metrics["fell"].shape[0]
        f = fitness({k: v.reshape(-1) for k, v in r.metrics.items()}, self.weights, self.units).reshape(P, self.k)
        agg = f.mean(axis=1) if self.how == "mean" else cvar(f, self.share)
        return agg, f, r.metrics, r.sim_steps

    def redrawn(self, opt, x: np.ndarray) -> Generation:
        """One generation of ``opt`` on its generation's draw; a DE's parents are scored
        again on the same draw (same call) and their fitness replaced by it before the
        selection."""
        x = np.atleast_2d(x)
        P = x.shape[0]
        parents = opt.pop if isinstance(opt, DifferentialEvolution) and opt.pop is not None else None
        both = x if parents is None else np.vstack([x, parents])
        agg, f, m, steps = self.score(both, opt.generation)
        if parents is not None:
            opt.fit = agg[P:].copy()  # Eq. 10 then compares trial and parent on the same models
        if isinstance(opt, DifferentialEvolution):  # the search's (not the random-search control's) last draw
            self.last = {"generation": opt.generation, "x": both, "f": f}
        return Generation(agg[:P], {"fell": int(np.sum(m["fell"][:P]))}, {"sim_steps": steps},
                          evaluations=both.shape[0] * self.k)

    def metrics_of(self, x: np.ndarray) -> dict | None:
        return None  # no walk on the nominal model at hand: the goal walks one

    def describe(self, best_x: np.ndarray, generation: int) -> dict:
        """The summary's block: the aggregate, K, the stream, how parents are handled, and
        the answer's fitness on each model of the search's last draw (``generation``)."""
        rows = np.array([], dtype=int)
        if self.last is not None and self.last["generation"] == generation:
            rows = np.flatnonzero(np.all(self.last["x"] == best_x, axis=1))
        if rows.size:
            f = self.last["f"][rows[0]]
        else:  # a job resumed after its search: the same walks again (each walk is its own simulation)
            f = self.score(np.atleast_2d(best_x), generation)[1][0]
        return {"models": self.k, "aggregate": self.how, "cvar_share": self.share if self.how == "cvar" else None,
                "stream": "cases.SEARCH_STREAM of the job's seed, one draw of K models per generation",
                "parents": PARENTS_TEXT, "ranges": dict(RANDOM_RANGES), "ranges_text": RANGE_TEXT,
                "last_draw": {"generation": generation, "draws": draws_of(self.seed, self.k, generation),
                              "best_fitness_per_model": [float(v) for v in f]}}

    def close(self) -> None:
        self.ev.close()

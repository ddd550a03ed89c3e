"""The phases of a ``multigait`` job and the budget they share.

Every phase counts its work in the units of the spec's ``budget_formula`` (a simulated gait
set, a plan, a re-simulated tree node), reports progress over the whole job and stops on
cancel between units: the search and the random-search control between generations, the
post-search analysis (held-out plans, tree verification, reuse plans, robustness cases)
after every chunk of work. ``Budget.tick`` is the one place that does both.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.jobs.base import Cancelled, RunContext
from app.jobs.loop import Generation, run_search
from app.jobs.multigait.planner.costs import evaluate


class Budget:
    """Progress in budget units across phases; ``parts`` is the spec's ``budget_parts()``."""

    def __init__(self, ctx: RunContext, parts: dict[str, int]):
        self.ctx, self.parts = ctx, dict(parts)
        self.total = max(1, sum(parts.values()))
        self.done = 0
        self.phase = next(iter(parts))
        self.used: dict[str, int] = {name: 0 for name in parts}

    def offset(self, phase: str) -> int:
        names = list(self.parts)
        return sum(self.parts[n] for n in names[: names.index(phase)])

    def begin(self, phase: str) -> None:
        self.phase = phase
        self.done = max(self.done, self.offset(phase))

    def report(self, done_in_phase: int, info: dict[str, Any] | None = None) -> None:
        self.used[self.phase] = done_in_phase
        self.done = self.offset(self.phase) + done_in_phase
        self.ctx.progress(min(self.done, self.total), self.total, {"phase": self.phase, **(info or {})})

    def tick(self, n: int = 1) -> None:
        """``n`` more units of the current phase done: report, then stop if cancelled."""
        self.report(self.used[self.phase] + int(n))
        if self.ctx.is_cancelled():
            raise Cancelled()

    def check(self) -> None:
        if self.ctx.is_cancelled():
            raise Cancelled()

    def finish(self) -> None:
        self.ctx.progress(self.total, self.total, {"phase": "done"})


class _PhaseContext:
    """The run context one search phase sees: its checkpoint is ``ckpt[name]`` (the job's
    checkpoint holds every phase's), its progress goes through the job's ``Budget``."""

    def __init__(self, name: str, ctx: RunContext, ckpt: dict, budget: Budget):
        self.name, self.ctx, self.ckpt, self.budget = name, ctx, ckpt, budget
        self.artifact_dir = ctx.artifact_dir

    def load_checkpoint(self):
        return self.ckpt.get(self.name)

    def save_checkpoint(self, state: dict) -> None:
        self.ckpt[self.name] = state
        self.ctx.save_checkpoint(self.ckpt)

    def progress(self, done: int, total: int, info: dict) -> None:
        self.budget.report(info["evaluations"], info)

    def is_cancelled(self) -> bool:
        return self.ctx.is_cancelled()


def search_phase(name: str, opt, sim, spec, pmap, k: int, K: int, radius: float, budget: Budget,
                 ctx: RunContext, ckpt: dict, generations: int | None = None) -> dict:
    """One ask/tell search through the shared loop (app/jobs/loop.py: generation 0 is the
    initial swarm, ``generations`` more follow) with the job's evaluator (the gait sets
    simulated once, RRT-MP on the search's planner draws); checkpoints under ``ckpt[name]``
    after every generation, so a resumed job continues bit-identically. The spec's stop
    rules apply to the search; a control runs the ``generations`` the search ran."""
    sign = 1.0 if spec.cost == "coverage" else -1.0
    budget.begin(name)
    budget.used[name] = (ckpt.get(name) or {}).get("evaluations", 0)

    def generation(x):
        steps0 = sim.sim_steps
        ev = evaluate(sim, x, k, pmap, K, spec.cost, spec.seed, radius)
        columns = {"nodes_mean": float(ev.tree.n.mean())}
        if hasattr(opt, "diagnostics"):
            columns |= opt.diagnostics()
        return Generation(ev.fitness, columns, {"sim_steps": sim.sim_steps - steps0, "sim_s": ev.sim_s,
                                                "plan_s": ev.plan_s})

    G = spec.search.generations if generations is None else generations
    out = run_search(opt, generation, G, _PhaseContext(name, ctx, ckpt, budget), spec.stop if name == "search" else None,
                     sign=sign)
    t = out.totals
    return {"best_x": out.best_x, "best_value": sign * out.best_fitness, "history": out.history,
            "evaluations": out.evaluations, "wall_s": out.wall_s, "sim_s": t.get("sim_s", 0.0),
            "plan_s": t.get("plan_s", 0.0), "sim_steps": int(t.get("sim_steps", 0)), "stop_reason": out.stop_reason,
            "generations_run": out.generations_run}


def _stats(v: np.ndarray) -> dict[str, float]:
    return {"heldout_mean": float(v.mean()), "heldout_std": float(v.std()), "heldout_min": float(v.min()),
            "heldout_max": float(v.max())}


def controls_block(spec, search: dict, held: np.ndarray, control: dict | None, control_held: np.ndarray | None) -> list:
    """``summary["controls"]`` (shared format): the held-out re-scoring of the best, the random
    search at the same budget (with its own best re-scored the same way), and the first
    generation (the swarm's own random start)."""
    unit = "%" if spec.cost == "coverage" else "mu"
    better = "higher" if spec.cost == "coverage" else "lower"
    n = spec.controls.heldout_plans
    ins = search["best_value"]
    out = [{"name": "heldout_rescoring",
            "label": f"the final best gait set planned again on {n} fresh planner draws held out from selection",
            "evaluations": n,
            "metrics": {"in_sample": ins, **_stats(held), "change": float(held.mean() - ins)},
            "target_met": None,
            "note": f"in-sample {ins:.2f} {unit} (the draws the search selected on) vs held-out mean "
                    f"{held.mean():.2f} {unit} (std {held.std():.2f}); the held-out value is the one to expect"}]
    if control is not None:
        d_in = control["best_value"] - ins
        d_ho = float(control_held.mean() - held.mean())
        h = control["history"]
        out.append({"name": "random_search",
                    "label": "random search: gait sets drawn uniformly in the same bounds, same evaluator and "
                             "planner draws, same number of evaluations",
                    "evaluations": control["evaluations"],
                    "metrics": {"in_sample_best": control["best_value"], **_stats(control_held),
                                "first_generation_mean": h[0]["mean"], "last_generation_mean": h[-1]["mean"],
                                "search_minus_random_in_sample": -d_in, "search_minus_random_heldout": -d_ho},
                    "target_met": None,
                    "note": f"random search's best: {control['best_value']:.2f} {unit} in-sample, "
                            f"{control_held.mean():.2f} {unit} held-out, against the search's {ins:.2f} / "
                            f"{held.mean():.2f} ({better} is better); one seed decides nothing: the comparison "
                            "over seeds with its test is in docs/multigait.md"})
    h = search["history"]
    if h:
        out.append({"name": "first_generation",
                    "label": f"the search's first generation ({spec.search.particles} random gait sets)",
                    "evaluations": spec.search.particles,
                    "metrics": {"best": h[0]["generation_best"], "mean": h[0]["mean"]},
                    "target_met": None,
                    "note": "the final best is a best of many evaluations and the first generation's mean a mean "
                            "of few: compare the final best with the random-search control, not with this mean"})
    return out

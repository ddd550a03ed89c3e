"""The one search loop of every population-based kind: restore from a checkpoint, check
cancel, ask / evaluate / tell, append a history row, checkpoint, report progress, and stop
on the budget or on a stopping rule the user set.

Counting convention (docs/architecture.md): generation 0 is the initial population; a
search of G generations evaluates P x (G + 1) candidates and writes G + 1 history rows.
History columns mean the same for every optimizer:

- ``best``: the best objective so far (in the user's units and direction);
- ``generation_best``, ``mean``, ``worst``: over the candidates evaluated in that generation
  (not over a population after selection, which only DE has);
- ``evaluations``: candidates evaluated so far; then the kind's own columns.

The optimizer maximises ``fitness``; ``value = sign * fitness`` is what the user reads
(sign -1 for a cost to minimise, e.g. a distance).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from pydantic import Field

from app.jobs.base import Cancelled, RunContext, StrictModel

StopReason = Literal["generations", "target", "plateau", "wall_time"]


class StopRules(StrictModel):
    """When a search may stop before its last generation (all off by default, so a spec
    runs its full budget). A stop by wall time depends on the machine, so it is the one
    rule that can make the same spec and seed stop at a different generation."""

    target: float | None = Field(None, ge=-1e12, le=1e12,
                                 description="stop once the best value reaches this (in the objective's units and "
                                             "direction)")
    plateau_generations: int | None = Field(None, ge=1, le=10000,
                                            description="stop when the best has not improved by plateau_rel_tol "
                                                        "over this many generations")
    plateau_rel_tol: float = Field(1e-3, ge=0.0, le=1.0, description="relative improvement that counts")
    max_wall_s: float | None = Field(None, gt=0.0, le=7 * 86400.0,
                                     description="stop after the generation that passes this search wall time")


@dataclasses.dataclass
class Generation:
    """What a kind's evaluation of one batch returns."""

    fitness: np.ndarray  # (P,) maximised by the optimizer
    columns: dict[str, float] = dataclasses.field(default_factory=dict)  # the kind's extra history columns
    totals: dict[str, float] = dataclasses.field(default_factory=dict)  # summed over generations (sim_steps ...)
    evaluations: int | None = None  # when a candidate costs several (e.g. one per model): else len(fitness)


@dataclasses.dataclass
class Carry:
    """A kind's own state that must survive a kill as the optimizer's does (e.g. the
    evaluation row of the best candidate so far, which the optimizer does not keep): its
    ``save()`` rides in every checkpoint under ``key``; ``restore`` gets it back (None when
    the checkpoint has none) before a resumed search continues."""

    key: str
    save: Callable[[], Any]
    restore: Callable[[Any], None]


@dataclasses.dataclass
class SearchOutcome:
    best_x: np.ndarray
    best_fitness: float
    history: list[dict[str, Any]]
    evaluations: int
    totals: dict[str, float]
    wall_s: float  # search wall time, summed over resumed attempts
    stop_reason: StopReason
    generations_run: int  # including generation 0


def stop_reason(history: list[dict], rules: StopRules, sign: float, wall_s: float) -> StopReason | None:
    """Which rule, if any, stops the search after the last row of ``history``."""
    best = history[-1]["best"]
    if rules.target is not None and sign * best >= sign * rules.target:
        return "target"
    n = rules.plateau_generations
    if n is not None and len(history) > n:
        then = sign * history[-1 - n]["best"]
        if sign * best - then <= rules.plateau_rel_tol * max(abs(then), 1e-12):
            return "plateau"
    if rules.max_wall_s is not None and wall_s >= rules.max_wall_s:
        return "wall_time"
    return None


def run_search(opt, evaluate: Callable[[np.ndarray], Generation], generations: int, ctx: RunContext,
               rules: StopRules | None = None, sign: float = 1.0,
               progress_info: Callable[[dict], dict] | None = None, carry: Carry | None = None) -> SearchOutcome:
    """Run ``opt`` (ask/tell, maximises, ``state()``/``restore()`` JSON) for generations
    0..``generations`` unless a rule stops it first. Checkpoints after every generation
    (with ``carry``'s state when given); a restored run continues bit-identically."""
    rules = rules or StopRules()
    total = generations + 1
    history: list[dict[str, Any]] = []
    evaluations = 0
    totals: dict[str, float] = {}
    wall_before = 0.0
    reason: StopReason | None = None
    ckpt = ctx.load_checkpoint()
    if ckpt is not None:
        opt.restore(ckpt["optimizer"])
        history, evaluations, totals = ckpt["history"], ckpt["evaluations"], ckpt["totals"]
        wall_before, reason = ckpt["wall_s"], ckpt.get("stop_reason")
        if carry is not None:
            carry.restore(ckpt.get(carry.key))
    seg_start = time.perf_counter()
    while reason is None and opt.generation < total:
        if ctx.is_cancelled():
            raise Cancelled()
        x = opt.ask()
        gen = evaluate(x)
        f = np.asarray(gen.fitness, dtype=float)
        opt.tell(f)
        evaluations += len(f) if gen.evaluations is None else gen.evaluations
        for k, v in gen.totals.items():
            totals[k] = totals.get(k, 0) + v
        value = sign * f
        row = {"generation": opt.generation - 1, "best": sign * opt.best[1], "mean": float(np.mean(value)),
               "worst": float(sign * np.min(f)), "generation_best": float(sign * np.max(f))}
        row |= gen.columns
        row["evaluations"] = evaluations
        history.append(row)
        wall = wall_before + time.perf_counter() - seg_start
        reason = stop_reason(history, rules, sign, wall)
        state = {"optimizer": opt.state(), "history": history, "evaluations": evaluations, "totals": totals,
                 "wall_s": wall, "stop_reason": reason}
        if carry is not None:
            state[carry.key] = carry.save()
        ctx.save_checkpoint(state)
        info = {"generation": row["generation"], "best": row["best"], "mean": row["mean"], "worst": row["worst"],
                "evaluations": evaluations}
        if "sim_steps" in totals:
            info["sim_steps_per_s"] = totals["sim_steps"] / max(wall, 1e-9)
        if progress_info is not None:
            info = progress_info(info)
        ctx.progress(opt.generation if reason is None else total, total, info)
    best_x, best_f = opt.best
    return SearchOutcome(best_x=best_x, best_fitness=best_f, history=history, evaluations=evaluations, totals=totals,
                         wall_s=wall_before + time.perf_counter() - seg_start, stop_reason=reason or "generations",
                         generations_run=len(history))

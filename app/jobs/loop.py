"""The one search loop of every population-based kind: restore from a checkpoint, check
cancel, ask / evaluate / tell, append a history row, checkpoint, report progress, and stop
on the budget or on a stopping rule the user set.

Counting convention (docs/architecture.md): generation 0 is the initial population; a
search of G generations evaluates P x (G + 1) candidates and writes G + 1 history rows.
History columns mean the same for every optimizer:

- ``best``: the best objective so far (in the user's units and direction);
- ``generation_best``, ``mean``, ``worst``: over the candidates evaluated in that generation
  (not over a population after selection, which only DE has);
- ``evaluations``: candidates evaluated so far; then the kind's own columns;
- ``target_met`` (a search with a goal): 1 once the best so far meets the kind's physical
  target as the kind confirms it (a stop rule on the target, not on a value of F).

A kind may cut a candidate's evaluation short once it cannot change the optimizer's next
step (``Optimizer.selection_thresholds``) and tell a bound instead of its value; the row's
statistics skip those (``Generation.exact``).

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

StopReason = Literal["generations", "target", "target_met", "plateau", "wall_time"]


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
    # (P,) False where the fitness is only an upper bound (the candidate's evaluation was cut
    # short once it could not win its selection): the history's statistics skip those
    exact: np.ndarray | None = None
    # the fitness of a cheaper stand-in (e.g. a shorter walk): its ranking steers the
    # optimizer (``tell(..., provisional=True)``), but it is no value of the objective, so
    # the best so far and the stop rules pass over it; the row says ``provisional``
    provisional: bool = False


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
    time_to_target_s: float | None = None  # search wall time when the best first met the goal (run_search's goal)


def stop_reason(history: list[dict], rules: StopRules, sign: float, wall_s: float) -> StopReason | None:
    """Which rule, if any, stops the search after the last row of ``history``; none after
    a provisional row (its values are no objective's), and the plateau rule only looks back
    over rows that are not."""
    if history[-1].get("provisional"):
        return None
    best = history[-1]["best"]
    if rules.target is not None and sign * best >= sign * rules.target:
        return "target"
    n = rules.plateau_generations
    if n is not None and len(history) > n and not history[-1 - n].get("provisional"):
        then = sign * history[-1 - n]["best"]
        if sign * best - then <= rules.plateau_rel_tol * max(abs(then), 1e-12):
            return "plateau"
    if rules.max_wall_s is not None and wall_s >= rules.max_wall_s:
        return "wall_time"
    return None


@dataclasses.dataclass
class GoalCheck:
    """A kind's verdict on the best candidate so far against its physical target (the
    user's goal, not a value of the objective), and what checking it cost (confirmation
    re-runs are simulations too: they count in the search's evaluations and totals)."""

    met: bool
    evaluations: int = 0
    totals: dict[str, float] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class _State:
    """What a search carries from one generation to the next and through a checkpoint."""

    history: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    evaluations: int = 0
    totals: dict[str, float] = dataclasses.field(default_factory=dict)
    wall_before: float = 0.0
    reason: StopReason | None = None
    target_wall_s: float | None = None  # search wall time when the best first met the goal
    goal_x: list[float] | None = None  # the last best the goal was asked about, and its answer
    goal_met: bool = False

    @classmethod
    def restore(cls, ckpt: dict) -> "_State":
        goal = ckpt.get("goal") or {}
        return cls(ckpt["history"], ckpt["evaluations"], ckpt["totals"], ckpt["wall_s"], ckpt.get("stop_reason"),
                   goal.get("target_wall_s"), goal.get("x"), bool(goal.get("met", False)))

    def count(self, evaluations: int, totals: dict[str, float]) -> None:
        self.evaluations += evaluations
        for k, v in totals.items():
            self.totals[k] = self.totals.get(k, 0) + v


def _row(opt, gen: Generation, f: np.ndarray, sign: float, history: list[dict]) -> dict[str, Any]:
    """A history row; its per-generation statistics skip the values that are only bounds
    (``Generation.exact`` False: a walk cut short once it could not win its selection). A
    provisional row's best is the best of the provisional rows so far (the optimizer's best
    holds the objective's values only)."""
    exact = f if gen.exact is None or not np.any(gen.exact) else f[np.asarray(gen.exact, dtype=bool)]
    top = float(sign * np.max(exact))
    if gen.provisional:
        before = [r["best"] for r in history if r.get("provisional")]
        best = top if not before else (max if sign > 0 else min)(before[-1], top)
    else:
        best = sign * opt.best[1]
    row = {"generation": opt.generation - 1, "best": best, "mean": float(np.mean(sign * exact)),
           "worst": float(sign * np.min(exact)), "generation_best": top}
    return row | {"provisional": 1} if gen.provisional else row


def _check_goal(opt, st: _State, goal: Callable[[np.ndarray], GoalCheck]) -> bool:
    """The goal's verdict on the best so far, asked only when the best changed (the last
    best asked about and its answer ride in the checkpoint)."""
    x = opt.best[0]
    if st.goal_x is not None and np.array_equal(np.asarray(st.goal_x), x):
        return st.goal_met
    chk = goal(x)
    st.count(chk.evaluations, chk.totals)
    st.goal_x, st.goal_met = x.tolist(), bool(chk.met)
    return st.goal_met


def run_search(opt, evaluate: Callable[[np.ndarray], Generation], generations: int, ctx: RunContext,
               rules: StopRules | None = None, sign: float = 1.0,
               progress_info: Callable[[dict], dict] | None = None, carry: Carry | None = None,
               goal: Callable[[np.ndarray], GoalCheck] | None = None, stop_at_goal: bool = False) -> SearchOutcome:
    """Run ``opt`` (ask/tell, maximises, ``state()``/``restore()`` JSON) for generations
    0..``generations`` unless a rule stops it first. Checkpoints after every generation
    (with ``carry``'s state when given); a restored run continues bit-identically. With
    ``goal``, every row says whether the best so far meets the kind's physical target
    (``target_met``), the outcome when it first did, and ``stop_at_goal`` ends the search
    there (stop reason ``target_met``)."""
    rules = rules or StopRules()
    total = generations + 1
    st = _State()
    ckpt = ctx.load_checkpoint()
    if ckpt is not None:
        opt.restore(ckpt["optimizer"])
        st = _State.restore(ckpt)
        if carry is not None:
            carry.restore(ckpt.get(carry.key))
    seg_start = time.perf_counter()
    while st.reason is None and opt.generation < total:
        if ctx.is_cancelled():
            raise Cancelled()
        gen = evaluate(opt.ask())
        f = np.asarray(gen.fitness, dtype=float)
        opt.tell(f, provisional=True) if gen.provisional else opt.tell(f)
        st.count(len(f) if gen.evaluations is None else gen.evaluations, gen.totals)
        row = _row(opt, gen, f, sign, st.history) | gen.columns
        st.history.append(row)
        met = goal is not None and not gen.provisional and _check_goal(opt, st, goal)  # no best to judge yet
        if goal is not None:
            row["target_met"] = int(met)
        row["evaluations"] = st.evaluations
        wall = st.wall_before + time.perf_counter() - seg_start
        if met and st.target_wall_s is None:
            st.target_wall_s = wall
        st.reason = "target_met" if met and stop_at_goal else stop_reason(st.history, rules, sign, wall)
        _save(ctx, opt, st, wall, carry)
        _report(ctx, opt, st, row, wall, total, progress_info)
    best_x, best_f = opt.best
    return SearchOutcome(best_x=best_x, best_fitness=best_f, history=st.history, evaluations=st.evaluations,
                         totals=st.totals, wall_s=st.wall_before + time.perf_counter() - seg_start,
                         stop_reason=st.reason or "generations", generations_run=len(st.history),
                         time_to_target_s=st.target_wall_s)


def _save(ctx: RunContext, opt, st: _State, wall: float, carry: Carry | None) -> None:
    state = {"optimizer": opt.state(), "history": st.history, "evaluations": st.evaluations, "totals": st.totals,
             "wall_s": wall, "stop_reason": st.reason}
    if st.goal_x is not None:
        state["goal"] = {"x": st.goal_x, "met": st.goal_met, "target_wall_s": st.target_wall_s}
    if carry is not None:
        state[carry.key] = carry.save()
    ctx.save_checkpoint(state)


def _report(ctx: RunContext, opt, st: _State, row: dict, wall: float, total: int,
            progress_info: Callable[[dict], dict] | None) -> None:
    info = {"generation": row["generation"], "best": row["best"], "mean": row["mean"], "worst": row["worst"],
            "evaluations": st.evaluations}
    if "sim_steps" in st.totals:
        info["sim_steps_per_s"] = st.totals["sim_steps"] / max(wall, 1e-9)
    if "target_met" in row:
        info["target_met"] = row["target_met"]
    if progress_info is not None:
        info = progress_info(info)
    ctx.progress(opt.generation if st.reason is None else total, total, info)

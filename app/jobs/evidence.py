"""The evidence protocol, written once (DESIGN.md "Evidence, not just numbers").

Every kind's result carries, beside its answer, the same two blocks, built from the
records here and read by every view through them:

- ``summary["controls"]``: a list of ``ControlRow`` — the baseline, a random search over
  the same space at the same budget, and the method's parts switched off, each with its
  metrics and whether it meets the kind's target;
- ``summary["robustness"]``: a ``Robustness`` block — the answer re-simulated under the
  standard named cases (``CASES``: the timestep halved and quartered, friction, masses,
  payload, rough floor) plus the kind's own, each case judged against the same target;
  numerics (timestep) and physical cases are told apart by ``Case.group``.

Conventions every kind follows:

- the random-search control draws its own stream, ``control_seed(seed)``;
- a job made of several phases (search, control, re-runs) reports progress and keeps
  its checkpoint through ``Phases`` (one entry per phase, one progress bar);
- a kind's target is one ``Target`` (its text and its test), used by the summary, the
  page, the CLI and studies alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from app.jobs.base import Cancelled, RunContext
# the records live apart (they import nothing of the contract); every kind imports them from here
from app.jobs.records import (CASES, Case, CaseResult, ControlRow, Group, HeldOut, Robustness, Target, case,
                              controls_of, group_of, robustness_of, spread)

__all__ = ["CASES", "CONTROL_SEED_OFFSET", "Case", "CaseResult", "ControlRow", "Group", "HeldOut", "PhaseContext",
           "Phases", "Robustness", "Target", "case", "control_seed", "controls_of", "group_of", "robustness_of", "spread"]

# -- the control's random stream ------------------------------------------------------------

CONTROL_SEED_OFFSET = 7919  # a prime: the control's stream never starts where the search's does


def control_seed(seed: int) -> int:
    """The seed of the random-search control of a job seeded ``seed``: its own stream,
    reproducible from the job's seed alone."""
    return int(seed) + CONTROL_SEED_OFFSET


# -- the phases of one job ------------------------------------------------------------------

class Phases:
    """The phases of one job (a search, its equal-budget random-search control, the
    robustness re-runs ...), each with its own checkpoint entry and its own share of the
    progress bar, in budget units (usually evaluations).

        phases = Phases(ctx, {"search": P * (G + 1), "random_search": P * (G + 1), "robustness": 7})
        out = run_search(opt, evaluate, G, phases.context("search"), ...)
        rob = phases.context("robustness"); ...; rob.tick()

    The job's checkpoint is {phase name: that phase's checkpoint}; a phase resumed after a
    kill finds its own entry; a finished phase's entry may hold its result."""

    def __init__(self, ctx: RunContext, sizes: Mapping[str, int]):
        self.ctx = ctx
        self.sizes = dict(sizes)
        self.state: dict[str, Any] = ctx.load_checkpoint() or {}
        self.artifact_dir = getattr(ctx, "artifact_dir", None)

    def context(self, name: str) -> PhaseContext:
        offset = 0
        for n, size in self.sizes.items():
            if n == name:
                return PhaseContext(self, name, offset, size)
            offset += size
        raise KeyError(f"unknown phase {name!r}; phases: {list(self.sizes)}")

    @property
    def total(self) -> int:
        return max(1, sum(self.sizes.values()))

    def finish(self) -> None:
        self.ctx.progress(self.total, self.total, {"phase": "done"})


class PhaseContext:
    """A run context for one phase: checkpoints land in the job's checkpoint under the
    phase's name; progress is scaled into the phase's share of the job's total. Besides
    the ``RunContext`` methods (what ``run_search`` needs), ``tick`` counts units done by
    a phase that is not a search, and ``check`` raises ``Cancelled`` when asked to stop."""

    def __init__(self, phases: Phases, name: str, offset: int, size: int):
        self._phases, self.name, self._offset, self._size = phases, name, offset, size
        self.artifact_dir = phases.artifact_dir
        self.done = 0

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        share = round(self._size * done / total) if total else 0
        self._phases.ctx.progress(self._offset + share, self._phases.total, {"phase": self.name} | info)

    def tick(self, n: int = 1, info: dict[str, Any] | None = None) -> None:
        """``n`` more units of this phase done: report them, then stop if cancelled."""
        self.done = min(self._size, self.done + int(n))
        self._phases.ctx.progress(self._offset + self.done, self._phases.total, {"phase": self.name, **(info or {})})
        self.check()

    def check(self) -> None:
        if self._phases.ctx.is_cancelled():
            raise Cancelled()

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        self._phases.state[self.name] = state
        self._phases.ctx.save_checkpoint(self._phases.state)

    def load_checkpoint(self) -> dict[str, Any] | None:
        return self._phases.state.get(self.name)

    def is_cancelled(self) -> bool:
        return self._phases.ctx.is_cancelled()

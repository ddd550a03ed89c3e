"""A run context for the cancel tests of every kind: records the phase of each progress
report (the kind's test says how to read it from the info) and raises the cancel flag
once progress has entered `cancel_in`."""

from __future__ import annotations

import copy

from app.jobs.base import MemoryContext


class PhaseCtx(MemoryContext):
    def __init__(self, ckpt=None, cancel_in=None):
        super().__init__()
        self._ckpt = copy.deepcopy(ckpt)
        self.cancel_in = cancel_in
        self.phases = []
        self.done = []

    def phase_of(self, info: dict):
        """The phase a progress report belongs to; None: not one (not recorded)."""
        return info.get("phase")

    def progress(self, done, total, info):
        phase = self.phase_of(info)
        if phase is not None:
            self.phases.append(phase)
            self.done.append(done)

    def save_checkpoint(self, state):
        self._ckpt = copy.deepcopy(state)

    def is_cancelled(self):
        return self.cancel_in is not None and bool(self.phases) and self.phases[-1] == self.cancel_in


def assert_cancel_stops_in(run, spec, finished_ctx, phase: str, later: list[str], ctx_cls=PhaseCtx) -> None:
    """Resume a finished run's checkpoint with the flag raised inside ``phase``: the run
    raises Cancelled at the phase's first unit of work and no phase of ``later`` runs.
    The random-search control is taken out of the checkpoint when it is the phase tested,
    so that it runs again."""
    import pytest

    from app.jobs.base import Cancelled

    ckpt = copy.deepcopy(finished_ctx._ckpt)  # the finished searches: only the later phases run again
    if phase == "random_search":
        ckpt.pop("random_search")
    ctx = ctx_cls(ckpt=ckpt, cancel_in=phase)
    with pytest.raises(Cancelled):
        run(spec, ctx)
    assert ctx.phases[-1] == phase  # stopped inside the phase, nothing after it ran
    assert ctx.phases.count(phase) == 1  # at its first unit of work
    assert not set(ctx.phases) & set(later)

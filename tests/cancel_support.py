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

"""Batched native rollouts, as every kind's evaluator runs them: one ``mujoco.rollout`` call
per chunk of a walk over a whole population (a thread per core), with the ``MjData``\\ s,
the thread pool and the output buffers kept between calls (fresh arrays each chunk cost
page faults, not simulation). An evaluator owns one ``RolloutPool`` and calls ``run``."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from mujoco import rollout

from app.sim.threads import sim_threads


class RolloutPool:
    """``nthread`` datas of ``model`` (GAITMEND_SIM_THREADS by default) and the buffers the
    rollouts write into. Results do not depend on the thread count (tests/sim)."""

    def __init__(self, model: mujoco.MjModel, nthread: int | None = None):
        self.nthread = nthread or sim_threads()
        self.datas = [mujoco.MjData(model) for _ in range(self.nthread)]
        self._runner = rollout.Rollout(nthread=self.nthread) if self.nthread > 1 else None
        self._buffers: dict[str, np.ndarray] = {}

    def buffer(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A reused array of ``shape`` (grown when a larger one is asked for)."""
        n = math.prod(shape)
        buf = self._buffers.get(name)
        if buf is None or buf.size < n:
            buf = self._buffers[name] = np.empty(n)
        return buf[:n].reshape(shape)

    def run(self, model, state: np.ndarray, ctrl: np.ndarray, nstate: int, nsensordata: int):
        """One rollout of initial states (A, nstate) under controls (A, T, nu): (state,
        sensordata) of shapes (A, T, nstate) and (A, T, nsensordata), in the pool's buffers
        (valid until the next call). ``model``: one model, or a list of one per batch element."""
        A, T = ctrl.shape[:2]
        out = {"state": self.buffer("state", (A, T, nstate)),
               "sensordata": self.buffer("sensordata", (A, T, nsensordata))}
        if self._runner is not None:
            return self._runner.rollout(model, self.datas, state, ctrl, **out)
        return rollout.rollout(model, self.datas[0], state, ctrl, **out)

    def close(self) -> None:
        if self._runner is not None:
            self._runner.close()
            self._runner = None

"""The repertoire's gait controller: a periodic joint-space controller any robot with a leg
map runs. numpy only (no gaitmend import): the bundle ships this file byte for byte as
``controller/repertoire_controller.py``, so the robot runs the module the simulation ran.

A gait is a point x of the unit cube [0, 1]^(3 n + 1) for n driven joints (the archive's
solution), laid out as

    x[3 j + 0]  amplitude of joint j   A_j = x * amplitude * h_j
    x[3 j + 1]  phase of joint j       phi_j = x (in periods)
    x[3 j + 2]  offset of joint j      c_j = s_j + (2 x - 1) * offset * h_j
    x[3 n]      period (shared)        T = period_lo + x * (period_hi - period_lo)

where h_j is half of joint j's range [lo_j, hi_j], s_j its stance value (clipped into the
range) and ``amplitude``, ``offset`` the layout's fractions. The set-point at time t after
the gait starts is

    q_j(t) = clip(s_j + w(t) * (c_j - s_j + A_j sin(2 pi (t / T + phi_j))), lo_j, hi_j),

with w(t) = min(1, t / ramp) rising from the stance over the first ``ramp`` seconds (no
step change when the gait starts; ramp 0 starts at once); before the gait (t < 0, the
robot settling) q_j = s_j. Every set-point lies within its joint's range (the clip).
"""

from __future__ import annotations

import math

import numpy as np

PARAMS_PER_JOINT = 3  # amplitude, phase, offset


def n_params(n_joints: int) -> int:
    """Parameters of a gait for ``n_joints`` driven joints: three per joint and the period."""
    return PARAMS_PER_JOINT * int(n_joints) + 1


class Layout:
    """The joints a gait drives and the bounds the unit cube maps to (module doc).

    ``lo``, ``hi``, ``stance``: per driven joint (rad, or m for a slide), in the order of
    the robot's servos; ``amplitude`` and ``offset``: fractions of each joint's half range;
    ``period_s``: (lo, hi); ``ramp_s``: the gait's fade-in."""

    def __init__(self, lo, hi, stance, amplitude: float, offset: float, period_s, ramp_s: float = 0.0,
                 joints=None):
        self.lo = np.asarray(lo, dtype=float)
        self.hi = np.asarray(hi, dtype=float)
        if self.lo.shape != self.hi.shape or self.lo.ndim != 1 or not np.all(self.lo < self.hi):
            raise ValueError("lo and hi: one range per joint, lo < hi")
        self.stance = np.clip(np.asarray(stance, dtype=float), self.lo, self.hi)
        self.half = 0.5 * (self.hi - self.lo)
        self.amplitude, self.offset = float(amplitude), float(offset)
        self.period_s = (float(period_s[0]), float(period_s[1]))
        self.ramp_s = float(ramp_s)
        self.joints = list(joints) if joints is not None else [f"joint{j}" for j in range(self.lo.size)]

    @property
    def n_joints(self) -> int:
        return int(self.lo.size)

    @property
    def dim(self) -> int:
        return n_params(self.n_joints)

    def to_json(self) -> dict:
        return {"joints": self.joints, "lo": self.lo.tolist(), "hi": self.hi.tolist(), "stance": self.stance.tolist(),
                "amplitude": self.amplitude, "offset": self.offset, "period_s": list(self.period_s),
                "ramp_s": self.ramp_s}

    @classmethod
    def from_json(cls, d: dict) -> Layout:
        return cls(d["lo"], d["hi"], d["stance"], d["amplitude"], d["offset"], d["period_s"], d.get("ramp_s", 0.0),
                   d.get("joints"))

    # -- the gait's terms ----------------------------------------------------------------
    def terms(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(amplitude (P, n), phase (P, n), centre (P, n), period (P,)) of gaits x (P, dim)."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"gaits must be of shape (P, {self.dim}), got {x.shape}")
        x = np.clip(x, 0.0, 1.0)
        n = self.n_joints
        joint = x[:, : 3 * n].reshape(-1, n, PARAMS_PER_JOINT)
        amp = joint[..., 0] * self.amplitude * self.half
        phase = joint[..., 1]
        centre = self.stance + (2.0 * joint[..., 2] - 1.0) * self.offset * self.half
        lo, hi = self.period_s
        period = lo + x[:, 3 * n] * (hi - lo)
        return amp, phase, centre, period

    def setpoints(self, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Set-points (P, T, n) of gaits x (P, dim) at times t (T,) after the gait starts
        (negative: settling, the stance)."""
        amp, phase, centre, period = self.terms(x)
        t = np.asarray(t, dtype=float)
        ramp = np.ones_like(t) if self.ramp_s <= 0 else np.clip(np.minimum(t, self.ramp_s) / self.ramp_s, 0.0, 1.0)
        ramp = np.where(t < 0, 0.0, ramp)
        arg = 2.0 * math.pi * (t[None, :, None] / period[:, None, None] + phase[:, None, :])
        wave = centre[:, None, :] - self.stance + amp[:, None, :] * np.sin(arg)
        q = self.stance + ramp[None, :, None] * wave
        return np.clip(q, self.lo, self.hi)

    def setpoints_single(self, x: np.ndarray, t: float) -> np.ndarray:
        """One gait's set-points (n,) at one time: what a robot's control loop calls each tick."""
        return self.setpoints(np.asarray(x, dtype=float)[None], np.array([float(t)]))[0, 0]

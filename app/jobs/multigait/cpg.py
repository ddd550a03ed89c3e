"""Hopf central pattern generator, one oscillator per joint (paper 001, Eq. 2; Righetti &
Ijspeert 2008):

    dx/dt = alpha (mu - r^2) x - omega y
    dy/dt = beta  (mu - r^2) y + omega x
    omega = omega1 / (exp(-b y) + 1) + omega2 / (exp(b y) + 1),     r^2 = x^2 + y^2

The limit cycle is the circle r = sqrt(mu) (both growth terms vanish there and, for
alpha, beta > 0, it attracts), so the joint angle x swings with amplitude sqrt(mu) rad.
While y > 0 the oscillator turns at omega1 (swing), while y < 0 at omega2 (stance); b sets
how sharply omega switches between them. The output x is the joint's desired angle,
tracked by the module's PD servo.

A gait is the vector (mu, alpha, beta, omega1, omega2, b) per functional joint (6 m
numbers), with the paper's ranges for CoSMO modules (Sec. V). The paper gives no initial
state and no coupling: every oscillator starts at (x, y) = (0, Y0), i.e. at the joints'
rest angle, so a gait starts from the rest pose; the joints differ only through their own
parameters.

Integration is classic RK4 at the control rate, batched over candidates and joints (the
ODE has no feedback from the body, so the whole 30 s setpoint sequence is computed before
the rollout; the time loop is over steps, each step a handful of array operations on
all candidates at once).
"""

from __future__ import annotations

import numpy as np

PARAMS = ("mu", "alpha", "beta", "omega1", "omega2", "b")
LOWER = np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0])
UPPER = np.array([1.3, 50.0, 50.0, 4.0, 4.0, 0.5])
Y0 = 0.1


def gait_bounds(n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of one gait's parameter vector, joint-major: (mu_1, alpha_1, ..., b_m)."""
    return np.tile(LOWER, n_joints), np.tile(UPPER, n_joints)


def param_names(joints: list[int]) -> list[str]:
    return [f"{p}_{j}" for j in joints for p in PARAMS]


def _rhs(x, y, mu, alpha, beta, wm, wd, hb):
    # omega = w1 / (exp(-b y) + 1) + w2 / (exp(b y) + 1) = wm + wd tanh(b y / 2), with
    # wm = (w1 + w2) / 2, wd = (w1 - w2) / 2, hb = b / 2: the same function in fewer array
    # operations and without overflow (the reference test integrates the typeset form).
    omega = wm + wd * np.tanh(hb * y)
    g = mu - (x * x + y * y)
    return (alpha * g) * x - omega * y, (beta * g) * y + omega * x


def hopf(params: np.ndarray, n_steps: int, dt: float, substeps: int = 1,
         x0: float = 0.0, y0: float = Y0) -> tuple[np.ndarray, np.ndarray]:
    """Integrate oscillators. ``params`` (..., 6) in PARAMS order; returns x, y of shape
    (n_steps, ...) sampled at t = 0, dt, ..., (n_steps - 1) dt."""
    p = np.asarray(params, dtype=float)
    if p.shape[-1] != 6:
        raise ValueError(f"Hopf parameters must end in 6 numbers {PARAMS}, got shape {p.shape}")
    mu, alpha, beta, w1, w2, b = (np.ascontiguousarray(p[..., i]) for i in range(6))
    x = np.full(mu.shape, float(x0))
    y = np.full(mu.shape, float(y0))
    xs = np.empty((n_steps,) + mu.shape)
    ys = np.empty((n_steps,) + mu.shape)
    h = dt / substeps
    args = (mu, alpha, beta, 0.5 * (w1 + w2), 0.5 * (w1 - w2), 0.5 * b)
    for t in range(n_steps):
        xs[t], ys[t] = x, y
        for _ in range(substeps):
            k1x, k1y = _rhs(x, y, *args)
            k2x, k2y = _rhs(x + (0.5 * h) * k1x, y + (0.5 * h) * k1y, *args)
            k3x, k3y = _rhs(x + (0.5 * h) * k2x, y + (0.5 * h) * k2y, *args)
            k4x, k4y = _rhs(x + h * k3x, y + h * k3y, *args)
            x = x + (h / 6.0) * (k1x + k4x + 2.0 * (k2x + k3x))
            y = y + (h / 6.0) * (k1y + k4y + 2.0 * (k2y + k3y))
    return xs, ys


def gait_setpoints(params: np.ndarray, n_joints: int, n_gait: int, n_settle: int, dt: float,
                   limit: float) -> np.ndarray:
    """Joint setpoints (B, n_gait + n_settle, n_joints) for B gait vectors (B, 6 n_joints).

    The CPG runs for ``n_gait`` steps (tau^p); then the setpoints ramp linearly to the rest
    pose over the first half of ``n_settle`` and hold it for the second half, so every gait
    ends with the joints near rest: what makes gaits composable (see app/jobs/multigait/planner/primitives).
    Setpoints are clipped to the hinge range."""
    p = np.atleast_2d(np.asarray(params, dtype=float))
    if p.shape[1] != 6 * n_joints:
        raise ValueError(f"a gait vector for {n_joints} joints has {6 * n_joints} numbers, got {p.shape[1]}")
    xs, _ = hopf(p.reshape(p.shape[0], n_joints, 6), n_gait + 1, dt)
    q = np.moveaxis(xs, 0, 1)  # (B, n_gait + 1, J)
    ramp_n = n_settle // 2
    ramp = np.clip(1.0 - np.arange(1, n_settle + 1) / max(ramp_n, 1), 0.0, 1.0)
    settle = q[:, -1:, :] * ramp[None, :, None]
    return np.clip(np.concatenate([q[:, :n_gait], settle], axis=1), -limit, limit)

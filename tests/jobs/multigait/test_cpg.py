"""Hopf CPG (paper 001, Eq. 2): limit cycle, swing/stance frequencies, RK4 vs a reference."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from app.jobs.multigait.cpg import LOWER, UPPER, gait_bounds, gait_setpoints, hopf


def _steady(p, seconds=40.0, dt=0.002):
    xs, ys = hopf(np.asarray(p, float), int(seconds / dt), dt)
    n = xs.shape[0]
    return xs[n // 2 :], ys[n // 2 :], dt


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.3])
def test_limit_cycle_amplitude_is_sqrt_mu(mu):
    x, y, _ = _steady([mu, 10.0, 10.0, 2.0, 2.0, 0.0])
    r = np.hypot(x, y)
    assert np.allclose(r, np.sqrt(mu), atol=1e-3)
    assert abs(x.max() - np.sqrt(mu)) < 5e-3 and abs(x.min() + np.sqrt(mu)) < 5e-3


def test_amplitude_reached_from_inside_and_outside():
    for x0, y0 in ((0.0, 0.05), (1.5, 0.0)):
        xs, ys = hopf(np.array([0.5, 5.0, 5.0, 1.0, 1.0, 0.0]), 5000, 0.004, x0=x0, y0=y0)
        assert abs(np.hypot(xs[-1], ys[-1]) - np.sqrt(0.5)) < 1e-3


@pytest.mark.parametrize("w1,w2", [(1.0, 3.0), (2.5, 0.8)])
def test_swing_and_stance_frequencies(w1, w2):
    # A sharp switch (large b) makes the oscillator turn at omega1 while y > 0 (swing)
    # and at omega2 while y < 0 (stance): half-cycles last pi/omega1 and pi/omega2.
    x, y, dt = _steady([1.0, 30.0, 30.0, w1, w2, 60.0], seconds=40.0, dt=0.002)
    up = np.nonzero((y[:-1] <= 0) & (y[1:] > 0))[0]
    down = np.nonzero((y[:-1] > 0) & (y[1:] <= 0))[0]
    down = down[down > up[0]]
    swing = (down[: len(up) - 1] - up[: len(down[: len(up) - 1])]) * dt
    stance = (up[1 : len(down) + 1] - down[: len(up) - 1]) * dt
    assert np.allclose(swing, np.pi / w1, rtol=0.06)
    assert np.allclose(stance, np.pi / w2, rtol=0.06)
    assert not np.allclose(np.pi / w1, np.pi / w2, rtol=0.2)


def test_zero_b_blends_the_two_frequencies():
    x, y, dt = _steady([1.0, 20.0, 20.0, 1.0, 3.0, 0.0], seconds=40.0, dt=0.002)
    up = np.nonzero((y[:-1] <= 0) & (y[1:] > 0))[0]
    period = np.mean(np.diff(up)) * dt
    assert abs(period - 2 * np.pi / 2.0) < 0.02  # omega = (w1 + w2) / 2 everywhere


def test_rk4_matches_reference_integrator():
    rng = np.random.default_rng(3)
    p = LOWER + rng.random((4, 6)) * (UPPER - LOWER)
    dt, n = 0.01, 800
    xs, ys = hopf(p, n, dt)
    for i in range(4):
        mu, a, be, w1, w2, b = p[i]

        def f(t, s):
            x, y = s
            om = w1 / (np.exp(-b * y) + 1) + w2 / (np.exp(b * y) + 1)
            g = mu - x * x - y * y
            return [a * g * x - om * y, be * g * y + om * x]

        ref = solve_ivp(f, (0, (n - 1) * dt), [0.0, 0.1], t_eval=np.arange(n) * dt, rtol=1e-10, atol=1e-12,
                        method="DOP853")
        assert np.max(np.abs(ref.y[0] - xs[:, i])) < 2e-3


def test_setpoints_shape_settle_and_clip():
    lo, hi = gait_bounds(3)
    assert lo.shape == (18,) and np.all(lo <= hi)
    rng = np.random.default_rng(0)
    g = lo + rng.random((5, 18)) * (hi - lo)
    q = gait_setpoints(g, 3, 300, 100, 0.01, limit=0.9)
    assert q.shape == (5, 400, 3)
    assert np.all(np.abs(q) <= 0.9)
    assert np.all(q[:, 350:] == 0.0)  # held at rest in the second half of the settle phase
    assert np.all(q[:, 0] == 0.0)  # starts at the rest angle (x0 = 0)
    with pytest.raises(ValueError, match="18 numbers"):
        gait_setpoints(g[:, :12], 3, 10, 10, 0.01, 1.0)

"""The residual QP (paper 003, Eq. 10): friction, signs and the trunk equations."""

import math

import numpy as np
import pytest

from app.jobs.energy.dynamics.qp import residual_qp


def _case(rng, S=30):
    arms = rng.uniform([-0.4, -0.25, -0.55], [0.4, 0.25, -0.45], size=(S, 4, 3))
    R = np.tile(np.eye(3), (S, 1, 1))
    stance = np.zeros((S, 4), bool)
    stance[:, [0, 3]] = True
    return arms, R, stance


def _wrench(arms, R, f):
    torque = np.cross(arms, f).sum(1)
    return np.concatenate([f.sum(1), np.einsum("sji,sj->si", R, torque)], axis=1)


def test_qp_recovers_a_feasible_wrench_exactly_and_keeps_friction():
    rng = np.random.default_rng(0)
    arms, R, stance = _case(rng)
    mu = 0.6
    # True forces strictly inside the inscribed pyramid.
    fz = rng.uniform(50, 200, size=(30, 4))
    f_true = np.stack([rng.uniform(-0.3, 0.3, (30, 4)) * fz, rng.uniform(-0.3, 0.3, (30, 4)) * fz, fz], axis=2)
    f_true[:, [1, 2]] = 0.0
    b = _wrench(arms, R, f_true)
    # A poor reference (the NLP's guess): the QP must still meet the equations.
    f_ref = f_true * 0.7
    none = np.zeros_like(stance)
    f, status = residual_qp(b, arms, R, stance, none, none, f_ref, mu, 260.0)
    assert (status == 0).all()
    assert _wrench(arms, R, f) == pytest.approx(b, abs=1e-3)
    assert np.abs(f[:, [1, 2]]).max() == 0.0


def test_qp_keeps_friction_and_signs_when_the_wrench_asks_for_more():
    rng = np.random.default_rng(1)
    arms, R, stance = _case(rng, S=20)
    mu = 0.6
    b = np.zeros((20, 6))
    b[:, 2] = 260.0
    b[:, 0] = 400.0  # far more forward push than friction allows
    first = np.zeros_like(stance)
    last = np.zeros_like(stance)
    first[:10] = stance[:10]  # demand braking on the first half
    last[10:] = stance[10:]
    f, status = residual_qp(b, arms, R, stance, first, last, np.zeros((20, 4, 3)), mu, 260.0)
    assert (status == 0).all()
    lim = mu / math.sqrt(2) * f[..., 2] + 1e-6
    assert (np.abs(f[..., 0]) <= lim).all() and (np.abs(f[..., 1]) <= lim).all()
    assert (f[..., 2] >= -1e-9).all()
    assert (f[:10][first[:10]][:, 0] <= 1e-9).all()
    assert (f[10:][last[10:]][:, 0] >= -1e-9).all()
    assert np.abs(_wrench(arms, R, f) - b).max() > 1.0  # it cannot meet that wrench, and says so

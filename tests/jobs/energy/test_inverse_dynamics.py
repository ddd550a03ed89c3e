"""The dummy legs' pull on the trunk (mj_inverse on the whole model) against momentum balance
computed independently from MuJoCo's kinematic momenta (mj_subtreeVel) and differentiated in
time: d P / dt = sum F_ext and d H_r / dt + v_r x P = sum M_r for a trunk moving uniformly."""

import mujoco
import numpy as np
import pytest

from app.jobs.energy.dynamics.dummy_legs import dummy_leg_wrench, nominal_body
from app.jobs.energy.dynamics.gait import Task, trot
from app.jobs.energy.dynamics.whole_body import GRAVITY, WholeBody, periodic_derivatives
from app.robots.quadruped import QUADRUPED25


@pytest.mark.parametrize("swing_height", [0.25, 0.35])
def test_dummy_leg_wrench_matches_momentum_balance(swing_height):
    g = QUADRUPED25
    task = Task(swing_height=swing_height)
    gait = trot(0.46)
    wb = WholeBody(g)
    K = 1000
    legs, f_l, m_l = dummy_leg_wrench(wb, gait, task, K)
    assert legs.reach_ok.all()
    t = legs.t
    r, th = nominal_body(task, t)
    m, d = wb.model, wb.data
    M = mujoco.mj_getTotalmass(m)
    P = np.zeros((K, 3))
    H = np.zeros((K, 3))  # about the trunk CoM (origin of the trunk frame)
    com = np.zeros((K, 3))
    qpos = wb.qpos(r, th, legs.q)
    v = np.zeros((K, 3))
    v[:, 0] = task.speed
    qvel = wb.qvec(v, np.zeros_like(v), legs.qd)
    for k in range(K):
        d.qpos[:], d.qvel[:] = qpos[k], qvel[k]
        mujoco.mj_forward(m, d)
        mujoco.mj_subtreeVel(m, d)
        b = m.body("trunk").id
        P[k] = M * d.subtree_linvel[b]
        com[k] = d.subtree_com[b]
        H[k] = d.subtree_angmom[b] + np.cross(com[k] - r[k], P[k])
    h = gait.period / K
    dP, _ = periodic_derivatives(P, h)
    # H about the trunk CoM is periodic: the motion relative to the trunk is.
    dH, _ = periodic_derivatives(H, h)
    hold_f = dP - M * np.array([0, 0, -GRAVITY])
    hold_m = dH + np.cross(v, P) - np.cross(com - r, M * np.array([0, 0, -GRAVITY]))
    trunk_hold = np.array([0, 0, g.trunk_mass * GRAVITY])
    f_expected = -(hold_f - trunk_hold)
    m_expected = -hold_m
    # Both sides differentiate sampled motion, whose acceleration jumps at touchdown: compare
    # in RMS over the period, against the RMS of the varying part of the signal.
    def rel(a, b):
        return np.sqrt(((a - b) ** 2).mean()) / np.sqrt(((b - b.mean(0)) ** 2).mean())

    assert np.abs(m_l).max() > 10.0  # Table 1's inertias make the legs' moment large: not vacuous
    assert rel(f_l, f_expected) < 0.01
    assert rel(m_l, m_expected) < 0.01

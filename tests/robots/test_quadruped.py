"""quadruped25: Table 1 masses, the link scaling rule, IK against MuJoCo's forward kinematics."""

import dataclasses

import mujoco
import numpy as np
import pytest

from app.robots.quadruped import LEGS, QUADRUPED25, build_model, leg_fk, leg_ik, qpos_index


def test_table1_masses_and_dofs():
    m = build_model(QUADRUPED25)
    assert (m.nq, m.nv, m.nu) == (19, 18, 12)
    assert mujoco.mj_getTotalmass(m) == pytest.approx(25.0 + 4 * (0.06 + 0.16 + 0.16))
    trunk = m.body("trunk").id
    assert m.body_inertia[trunk] == pytest.approx([0.35, 2.1, 2.1])
    # Table 1 as printed: thigh inertia 0.09 kg m^2 about the joint (transverse), 0.03 axial.
    thigh = m.body("FR_thigh").id
    about_joint = m.body_inertia[thigh][0] + m.body_mass[thigh] * (0.33 / 2) ** 2
    assert about_joint == pytest.approx(0.09)
    assert m.body_inertia[thigh][2] == pytest.approx(0.03)


def test_scaling_rule_keeps_density_and_positive_inertia():
    g = dataclasses.replace(QUADRUPED25, links=(0.09, 0.40, 0.25))
    assert g.masses() == pytest.approx([0.06 * 1.5, 0.16 * 0.40 / 0.33, 0.16 * 0.25 / 0.33])
    j = g.joint_inertias()
    assert j[1, 1] == pytest.approx(0.09 * (0.40 / 0.33) ** 3)
    assert j[1, 0] == pytest.approx(0.03 * 0.40 / 0.33)
    assert (g.com_inertias() > 0).all()
    rod = dataclasses.replace(QUADRUPED25, inertia="rod").joint_inertias()
    assert rod[1, 1] == pytest.approx(0.16 * 0.33**2 / 3)
    with pytest.raises(ValueError):
        dataclasses.replace(QUADRUPED25, inertia="made_up")


def test_ik_matches_mujoco_fk_on_random_reachable_points():
    g = QUADRUPED25
    m = build_model(g, floor=False)
    d = mujoco.MjData(m)
    qi = qpos_index(m)
    rng = np.random.default_rng(3)
    d.qpos[3] = 1.0
    checked = 0
    while checked < 50:
        q = rng.uniform([-0.5, -0.8, -2.0], [0.5, 0.8, -0.1], size=(4, 3))
        # The IK's branch: knee forward (q_knee < 0) and the tip below the thigh joint.
        if (-0.33 * np.cos(q[:, 1]) - 0.33 * np.cos(q[:, 1] + q[:, 2]) >= -0.02).any():
            continue
        checked += 1
        d.qpos[qi] = q.ravel()
        mujoco.mj_kinematics(m, d)
        for i, leg in enumerate(LEGS):
            tip = d.site(f"{leg}_tip").xpos - d.qpos[:3] - g.hip(leg)
            q_back, ok = leg_ik(tip, g.links, g.side(leg))
            assert ok
            assert leg_fk(q_back, g.links, g.side(leg)) == pytest.approx(tip, abs=1e-9)
            assert q_back == pytest.approx(q[i], abs=1e-7)


def test_ik_flags_unreachable_points():
    _, ok = leg_ik(np.array([0.0, -0.06, -0.70]), QUADRUPED25.links, -1)
    assert not ok

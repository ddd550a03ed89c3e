"""SILO-6 model: Table 1 masses and sizes, numbering, IK against MuJoCo forward kinematics,
workspaces reachable, standing still on flat ground."""

import itertools

import mujoco
import numpy as np
import pytest

from app.robots import silo6
from app.robots.silo6 import SENSOR_SLICES, SILO6


def test_table_1_masses_and_tripods():
    m = silo6.build_flat_spec().compile()
    assert sum(m.body_mass) == pytest.approx(54.0)  # Table 1: total mass
    assert sum(SILO6.link_masses) == pytest.approx(4.3)
    assert silo6.TRIPODS == ((1, 4, 5), (2, 3, 6))
    # odd legs left (+y), (1, 2) front, (5, 6) rear
    assert SILO6.hip(1)[1] > 0 > SILO6.hip(2)[1] and SILO6.hip(1)[0] > SILO6.hip(3)[0] > SILO6.hip(5)[0]
    assert SILO6.hip(1)[0] - SILO6.hip(3)[0] == pytest.approx(0.365)  # stroke pitch P_x
    r = SILO6.workspace_rect(1)
    assert r[1] - r[0] == pytest.approx(0.25)  # stroke R_x


def test_ik_matches_mujoco_forward_kinematics():
    spec = silo6.build_flat_spec()
    m = spec.compile()
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    ws = SILO6.workspaces()
    for _ in range(5):
        feet = np.stack([[rng.uniform(w[0], w[1]), rng.uniform(w[2], w[3]), rng.uniform(*SILO6.z_range)] for w in ws])
        q = silo6.leg_ik_body(SILO6, feet)
        d.qpos[:] = 0
        d.qpos[3] = 1.0
        d.qpos[2] = 1.0
        d.qpos[7:] = q.reshape(-1)
        mujoco.mj_forward(m, d)
        tips = d.sensordata[SENSOR_SLICES["tips"]].reshape(6, 3) - d.qpos[:3]
        np.testing.assert_allclose(tips, feet, atol=1e-9)
        np.testing.assert_allclose(silo6.leg_fk_body(SILO6, q), feet, atol=1e-12)


def test_every_workspace_corner_is_reachable_within_joint_ranges():
    lo = np.radians([r[0] for r in SILO6.joint_range_deg])
    hi = np.radians([r[1] for r in SILO6.joint_range_deg])
    for leg, w in zip(silo6.LEG_IDS, SILO6.workspaces()):
        for x, y, z in itertools.product(w[:2], w[2:], SILO6.z_range):
            feet = SILO6.nominal_feet()
            feet[leg - 1] = (x, y, z)
            q = silo6.leg_ik_body(SILO6, feet)
            np.testing.assert_allclose(silo6.leg_fk_body(SILO6, q)[leg - 1], (x, y, z), atol=1e-9)
            assert (q[leg - 1] >= lo).all() and (q[leg - 1] <= hi).all()


def test_stands_on_flat_ground():
    m = silo6.build_flat_spec().compile()
    d = mujoco.MjData(m)
    d.qpos[2] = SILO6.stand_height + SILO6.foot_radius
    d.qpos[3] = 1.0
    q = silo6.leg_ik_body(SILO6, SILO6.nominal_feet()).reshape(-1)
    d.qpos[7:] = q
    d.ctrl[:] = q
    for _ in range(1000):
        mujoco.mj_step(m, d)
    assert abs(d.qpos[2] - (SILO6.stand_height + SILO6.foot_radius)) < 0.02
    assert (d.sensordata[SENSOR_SLICES["touch"]] > 50).all()  # every foot switch closed under ~90 N

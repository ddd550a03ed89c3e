"""Damage is applied to the model itself: mass, joints and actuators change."""

import math

import mujoco
import numpy as np
import pytest

from app.robots.catalog import JETHEXA, get_robot
from app.robots.damage import DamageSpec, LockedJoint, WeakJoint


def test_intact_model():
    _, m = JETHEXA.model()
    assert (m.nu, m.njnt, m.nq) == (18, 19, 25)
    assert sum(m.body_mass) == pytest.approx(JETHEXA.geometry.total_mass)
    assert m.opt.timestep == JETHEXA.geometry.timestep


def test_lost_legs_remove_mass_joints_and_actuators():
    _, m = JETHEXA.model(DamageSpec(lost_legs=(1, 6)))
    leg_mass = sum(JETHEXA.geometry.link_masses)
    assert sum(m.body_mass) == pytest.approx(JETHEXA.geometry.total_mass - 2 * leg_mass)
    assert m.nu == 12 and m.nq == 7 + 12
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(m.nbody)}
    assert not any(n.startswith(("leg1_", "leg6_")) for n in names)


def test_locked_joint_is_welded_at_its_angle():
    angle = math.radians(30)
    spec, m = JETHEXA.model(DamageSpec(locked_joints=(LockedJoint(2, "femur", angle),)))
    assert m.nu == 17 and mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "leg2_femur") == -1
    d = mujoco.MjData(m)
    d.qpos[3] = 1
    mujoco.mj_kinematics(m, d)
    # Femur pitched up by 30 deg (axis -y in the leg frame): its far end rises by L2 sin 30.
    femur = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "leg2_femur")
    tibia = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "leg2_tibia")
    dz = d.xpos[tibia, 2] - d.xpos[femur, 2]
    assert dz == pytest.approx(JETHEXA.geometry.link_lengths[1] * math.sin(angle))


def test_weak_joint_scales_its_torque_limit():
    _, m = JETHEXA.model(DamageSpec(weak_joints=(WeakJoint(3, "tibia", 0.25),)))
    a = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "leg3_tibia_pid")
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "leg4_tibia_pid")
    np.testing.assert_allclose(m.actuator_forcerange[a], 0.25 * m.actuator_forcerange[b])


def test_actuators_are_the_papers_pid():
    _, m = JETHEXA.model()
    g = JETHEXA.geometry
    assert m.actuator_gainprm[0, 0] == g.ki  # integral gain on the act state
    np.testing.assert_allclose(m.actuator_biasprm[0, :3], [0, -g.kp, -g.kd])
    assert m.na == 18  # one integral state per joint


def test_unknown_robot():
    with pytest.raises(KeyError, match="unknown robot"):
        get_robot("atlas")

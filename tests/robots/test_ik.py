"""Closed-form IK (Eq. 11) against its own FK, the typeset formula and MuJoCo."""

import math

import mujoco
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.robots.ik import leg_fk, leg_ik, leg_ik_paper
from app.robots.catalog import JETHEXA
from app.robots.hexapod import leg_frame_quat

LENGTHS = JETHEXA.geometry.link_lengths

# The branch the gait uses: coxa within +-70 deg, femur within +-80 deg, knee bent down,
# tip outside the femur joint.
angles = st.tuples(
    st.floats(-1.2, 1.2), st.floats(-1.4, 1.4), st.floats(-2.9, -0.05),
).filter(lambda q: LENGTHS[1] * math.cos(q[1]) + LENGTHS[2] * math.cos(q[1] + q[2]) > 1e-3)


@settings(max_examples=300, deadline=None)
@given(angles)
def test_ik_round_trip(q):
    q = np.array(q)
    p = leg_fk(q, LENGTHS)
    np.testing.assert_allclose(leg_ik(p, LENGTHS), q, atol=1e-7)
    np.testing.assert_allclose(leg_fk(leg_ik(p, LENGTHS), LENGTHS), p, atol=1e-9)


def _typeset_branch(q):
    """Where Eq. 11's arctan/arcsin pick the right quadrant: the knee is not folded past
    arccos(-L2/L3) and the femur+gamma angle stays within +-90 deg."""
    _, L2, L3 = LENGTHS
    c = L2 + L3 * math.cos(q[2])
    gamma = math.atan(L3 * math.sin(q[2]) / c) if c > 0 else math.nan
    return c > 1e-3 and abs(q[1] + gamma) < math.pi / 2 - 1e-3


@settings(max_examples=200, deadline=None)
@given(angles.filter(_typeset_branch))
def test_typeset_eq11_agrees_on_its_branch(q):
    p = leg_fk(np.array(q), LENGTHS)
    np.testing.assert_allclose(leg_ik_paper(p, LENGTHS), leg_ik(p, LENGTHS), atol=1e-6)


def test_typeset_eq11_fails_when_the_knee_folds_far_and_atan2_does_not():
    """Why leg_ik uses atan2: with the knee folded past arccos(-L2/L3) the typeset arctan
    for gamma lands in the wrong quadrant; the atan2 form still inverts FK."""
    q = np.array([0.0, 1.0, -2.5])
    p = leg_fk(q, LENGTHS)
    assert not np.allclose(leg_ik_paper(p, LENGTHS), q, atol=1e-3)
    np.testing.assert_allclose(leg_ik(p, LENGTHS), q, atol=1e-9)


def test_ik_matches_mujoco_forward_kinematics():
    """Random reachable tip targets -> IK -> MuJoCo FK puts every tip site on its target."""
    _, model = JETHEXA.model()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    done = 0
    while done < 20:
        q = np.column_stack([rng.uniform(-1.0, 1.0, 6), rng.uniform(-1.0, 1.0, 6), rng.uniform(-2.6, -0.3, 6)])
        planar = LENGTHS[1] * np.cos(q[:, 1]) + LENGTHS[2] * np.cos(q[:, 1] + q[:, 2])
        if planar.min() < 5e-3:  # tip inside the femur joint: not the gait's branch
            continue
        done += 1
        targets = leg_fk(q, LENGTHS)  # (6, 3) in leg frames: reachable by construction
        sol = leg_ik(targets, LENGTHS)
        data.qpos[:] = 0
        data.qpos[3] = 1.0
        data.qpos[7:] = sol.ravel()  # joints are ordered leg1 coxa, femur, tibia, leg2 ...
        mujoco.mj_kinematics(model, data)
        for i, lg in enumerate(JETHEXA.geometry.legs()):
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, leg_frame_quat(lg.side))
            expected = np.array(lg.hip) + rot.reshape(3, 3) @ targets[i]
            site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"leg{lg.leg}_tip")
            np.testing.assert_allclose(data.site_xpos[site], expected, atol=1e-9)


def test_unreachable_targets_are_clamped_not_nan():
    """A target beyond the reach gets the fully stretched leg, one inside it the fully folded
    leg, each pointing from the femur joint at the target: the tip lands where the ray from
    the femur joint to the target meets the reach's outer (L2 + L3) or inner (|L2 - L3|)
    sphere, worked out here by hand. A target on the boundary, where rounding pushes the
    cosine past 1, is reached exactly."""
    L1, L2, L3 = LENGTHS
    far = [[1.0, 0.0, -0.5], [0.1, 0.3, 0.2], [-0.2, -0.1, -0.3]]
    near = [[0.0, 0.0, 0.0], [0.03, 0.02, -0.01], [0.04, -0.01, 0.02]]
    for targets, reach in ((far, L2 + L3), (near, abs(L2 - L3))):
        p = np.array(targets)
        sol = leg_ik(p, LENGTHS)
        assert np.all(np.isfinite(sol))
        yaw = np.arctan2(p[:, 1], p[:, 0])
        joint = np.column_stack([L1 * np.cos(yaw), L1 * np.sin(yaw), np.zeros(len(p))])  # the femur joint
        ray = (p - joint) / np.linalg.norm(p - joint, axis=1, keepdims=True)
        dist = np.linalg.norm(p - joint, axis=1)
        assert np.all(dist > reach) if reach == L2 + L3 else np.all(dist < reach)  # unreachable indeed
        np.testing.assert_allclose(leg_fk(sol, LENGTHS), joint + reach * ray, atol=1e-9)
    edge = leg_fk(np.array([[0.3, a, 0.0] for a in np.linspace(-1.2, 1.2, 25)]), LENGTHS)
    sol = leg_ik(edge, LENGTHS)
    assert np.all(np.isfinite(sol))
    np.testing.assert_allclose(leg_fk(sol, LENGTHS), edge, atol=1e-9)

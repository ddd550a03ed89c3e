"""Robots as data (issue 23): the leg map model, the JetHexa as an entry of that form,
leg detection on robots nobody here wrote, and the batched numerical IK (against MuJoCo's
own kinematics and against the closed form on the JetHexa's legs)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings, strategies as st

sys.path.insert(0, str(Path(__file__).parent))
import legged_models as lm_  # noqa: E402

from app.robots import hexapod  # noqa: E402
from app.robots.catalog import JETHEXA  # noqa: E402
from app.robots.detect import check_legs, detect_legs, leg_points  # noqa: E402
from app.robots.ik import leg_ik  # noqa: E402
from app.robots.legmap import LegMap, LegMapError  # noqa: E402
from app.robots.numik import LegIK  # noqa: E402


@pytest.fixture(scope="module")
def jethexa():
    model = JETHEXA.build().compile()
    legs = JETHEXA.leg_map()
    return model, legs, LegIK(model, legs)


# -- the leg map ----------------------------------------------------------------------------

def test_leg_map_round_trips_through_json_and_is_strict():
    legs = JETHEXA.leg_map()
    assert LegMap.parse(legs.to_json()) == legs
    doc = legs.to_json()
    for bad, why in [({**doc, "extra": 1}, "extra"), ({**doc, "legs": []}, "at least 1"),
                     ({**doc, "stance_height": float("nan")}, "stance_height"),
                     ({**doc, "stance_height": 11.0}, "stance_height"),
                     ({**doc, "legs": [doc["legs"][0], doc["legs"][0]]}, "repeat"),
                     ({**doc, "legs": [{**doc["legs"][0], "joints": ["a", "a"]}]}, "twice"),
                     ({**doc, "legs": [{**doc["legs"][0], "stance": [0.0]}]}, "stance"),
                     ({**doc, "legs": [{**doc["legs"][0], "name": "../x"}]}, "name"),
                     ({**doc, "legs": [doc["legs"][0]] * 17}, "16"),
                     ({**doc, "gains": {"kp": -1}}, "kp")]:
        with pytest.raises(LegMapError) as e:
            LegMap.parse(bad)
        assert e.value.args[0], why
    with pytest.raises(LegMapError):
        LegMap.parse(b"{not json")


def test_jethexa_is_an_entry_of_that_form_and_its_model_is_unchanged():
    robot = JETHEXA.robot()
    assert robot.mjcf == hexapod.build_spec(hexapod.JETHEXA).to_xml()  # the very model the kind builds
    model = robot.model()
    ref = JETHEXA.build().compile()
    assert (model.nbody, model.njnt, model.nu, model.nsensor) == (ref.nbody, ref.njnt, ref.nu, ref.nsensor)
    np.testing.assert_allclose(model.body_pos, ref.body_pos, atol=1e-12)
    legs = robot.legs
    assert [l.name for l in legs.legs] == [f"leg{n}" for n in range(1, 7)]
    assert legs.gains.kp == 500.0 and legs.stance_height == JETHEXA.stance_height
    check_legs(model, legs)
    assert len(robot.content_hash()) == 64


def test_detection_finds_the_jethexa_legs_as_the_entry_declares_them():
    model = JETHEXA.build().compile()
    found, declared = detect_legs(model), JETHEXA.leg_map()
    assert found.forward == declared.forward == "+y" and found.trunk == "torso"
    key = lambda m: sorted((l.name, l.side, l.order, tuple(l.joints), l.foot.kind, l.foot.name) for l in m.legs)
    assert key(found) == key(declared)


@pytest.mark.parametrize("layout", lm_.LAYOUTS, ids=lambda l: l.name)
def test_detection_on_robots_built_here(layout):
    model = lm_.build(layout).compile()
    legs = detect_legs(model)
    assert len(legs.legs) == 2 * layout.pairs
    for leg in legs.legs:
        side, k = leg.name[0], int(leg.name[1])
        assert leg.side == {"L": "left", "R": "right"}[side] and leg.order == k
        assert leg.joints == [f"{leg.name}_j{i}" for i in range(len(layout.joints))]
        assert leg.foot.name == f"{leg.name}_tip" if layout.foot_site else f"{leg.name}_foot"
    check_legs(model, legs)
    pts = leg_points(model, legs)
    assert all(pts[l.name]["hip"][1] > 0 for l in legs.legs if l.side == "left")


def test_a_leg_map_that_does_not_fit_the_model_is_refused():
    model = JETHEXA.build().compile()
    doc = JETHEXA.leg_map().to_json()
    cases = [({**doc, "trunk": "nope"}, "no body"),
             ({**doc, "legs": [{**doc["legs"][0], "joints": ["leg1_femur", "leg1_coxa", "leg1_tibia"]}]}, "in order"),
             ({**doc, "legs": [{**doc["legs"][0], "joints": ["leg1_coxa", "leg1_femur"], "stance": None}]}, "in order"),
             ({**doc, "legs": [{**doc["legs"][0], "joints": ["leg1_coxa", "leg1_femur", "root"]}]}, "hinge"),
             ({**doc, "legs": [{**doc["legs"][0], "foot": {"kind": "site", "name": "imu"}}]}, "in order"),
             ({**doc, "legs": [{**doc["legs"][0], "foot": {"kind": "geom", "name": "floor"}}]}, "not on a body")]
    for bad, words in cases:
        with pytest.raises(LegMapError, match=words):
            check_legs(model, LegMap.parse(bad))


# -- third-party models shipped in wheels -----------------------------------------------------

def test_gymnasium_ant_legs_are_found():
    path = lm_.gymnasium_ant()
    assert path is not None, "gymnasium is missing: the test extra brings it (pip install -e '.[test]')"
    model = mujoco.MjModel.from_xml_path(str(path))
    legs = detect_legs(model)
    assert legs.trunk == "torso" and len(legs.legs) == 4
    assert sorted(tuple(l.joints) for l in legs.legs) == [(f"hip_{i}", f"ankle_{i}") for i in range(1, 5)]
    assert all(l.foot.kind == "geom" and l.foot.name.endswith("ankle_geom") and abs(l.foot.offset[2]) > 0.28
               for l in legs.legs)
    assert sorted((l.side, l.order) for l in legs.legs) == [("left", 0), ("left", 1), ("right", 0), ("right", 1)]
    _ik_reaches(model, legs, span=0.25)


def test_dm_control_quadruped_legs_are_found():
    path = lm_.dm_control_quadruped()
    assert path is not None, "dm_control is missing: the test extra brings it (pip install -e '.[test]')"
    model = mujoco.MjModel.from_xml_path(str(path))
    legs = detect_legs(model)
    assert legs.trunk == "torso" and legs.forward == "+x"  # the ball's free joint is not the trunk
    assert sorted(l.name for l in legs.legs) == ["back_left", "back_right", "front_left", "front_right"]
    for l in legs.legs:
        assert l.joints == [f"{j}_{l.name}" for j in ("yaw", "pitch", "knee", "ankle")]
        assert (l.foot.kind, l.foot.name) == ("site", f"toe_{l.name}")
        assert l.side == l.name.split("_")[1] and l.order == (0 if l.name.startswith("front") else 1)
    _ik_reaches(model, legs, span=0.3)


def _ik_reaches(model, legs, span):
    ik = LegIK(model, legs)
    rng = np.random.default_rng(7)
    half = np.where(np.isfinite(ik.hi), (ik.hi - ik.lo) / 2, span)
    mid = np.where(np.isfinite(ik.hi), (ik.hi + ik.lo) / 2, ik.q_ref)
    q = mid + rng.uniform(-0.8, 0.8, (200, ik.nq)) * half
    result = ik.solve(ik.fk(q), q0=mid)
    assert result.reached(1e-8).mean() > 0.97, result.err.max()
    _agrees_with_mujoco(model, legs, result.q[:5], ik.fk(result.q[:5]))


# -- the numerical IK ---------------------------------------------------------------------------

def _agrees_with_mujoco(model, legs, qs, feet):
    data = mujoco.MjData(model)
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, legs.trunk)
    adr = [model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in legs.joint_names()]
    for q, f in zip(qs, feet):
        data.qpos[:] = model.qpos0
        data.qpos[adr] = q
        mujoco.mj_kinematics(model, data)
        R, p = data.xmat[trunk].reshape(3, 3), data.xpos[trunk]
        for leg, point in zip(legs.legs, f):
            obj = {"site": (mujoco.mjtObj.mjOBJ_SITE, data.site_xpos, data.site_xmat),
                   "geom": (mujoco.mjtObj.mjOBJ_GEOM, data.geom_xpos, data.geom_xmat),
                   "body": (mujoco.mjtObj.mjOBJ_BODY, data.xpos, data.xmat)}[leg.foot.kind]
            i = mujoco.mj_name2id(model, obj[0], leg.foot.name)
            world = obj[1][i] + obj[2][i].reshape(3, 3) @ np.array(leg.foot.offset)
            np.testing.assert_allclose(R.T @ (world - p), point, atol=1e-9)


@pytest.mark.parametrize("layout", lm_.LAYOUTS, ids=lambda l: l.name)
def test_numerical_ik_reaches_targets_on_other_layouts(layout):
    model = lm_.build(layout).compile()
    legs = detect_legs(model)
    ik = LegIK(model, legs)
    rng = np.random.default_rng(3)
    span = np.where(np.isfinite(ik.lo), np.minimum(0.4, (ik.hi - ik.lo) / 2), 0.4)
    q = np.clip(ik.q_ref + rng.uniform(-1, 1, (4, 25, ik.nq)) * span, ik.lo, ik.hi)  # (P, T, nq)
    targets = ik.fk(q)
    assert targets.shape == (4, 25, len(legs.legs), 3)
    result = ik.solve(targets)
    assert result.q.shape == (4, 25, ik.nq) and result.err.shape == (4, 25, len(legs.legs))
    assert result.err.max() < 1e-9
    _agrees_with_mujoco(model, legs, result.q.reshape(-1, ik.nq)[:6], targets.reshape(-1, len(legs.legs), 3)[:6])


def test_the_jacobian_is_mujocos(jethexa):
    model, legs, ik = jethexa
    data = mujoco.MjData(model)
    q = np.array(ik.q_ref) + 0.1
    adr = [model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in legs.joint_names()]
    data.qpos[:] = model.qpos0
    data.qpos[adr] = q
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    for i, leg in enumerate(legs.legs):
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot.name)
        jacp = np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jacp, None, site)
        dof = [model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in leg.joints]
        _, J = ik.jacobian(q[None, ik.cols[i]], i)
        np.testing.assert_allclose(J[0], jacp[:, dof], atol=1e-12)  # trunk at the origin, unrotated


def test_unreachable_targets_say_how_far_they_are(jethexa):
    _, legs, ik = jethexa
    far = np.array(ik.rest_feet) * 10.0
    result = ik.solve(far[None], max_iter=30)
    assert (result.err > 0.1).all() and np.isfinite(result.q).all()
    assert ((result.q >= ik.lo - 1e-12) & (result.q <= ik.hi + 1e-12)).all()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.floats(0.06, 0.16), st.floats(-0.06, 0.06), st.floats(-0.14, -0.04)),
                min_size=6, max_size=6))
def test_numerical_ik_agrees_with_the_closed_form_on_jethexa_legs(jethexa, tips):
    """Random reachable targets (leg frame: x outward, y forward, z up; |tip| within the
    leg's reach): the numerical answer and the closed form put each foot at the target
    within 1e-6 m and agree on the joint angles."""
    model, legs, ik = jethexa
    L1, L2, L3 = hexapod.JETHEXA.link_lengths
    p = np.array(tips)
    r = np.hypot(p[:, 0], p[:, 1]) - L1
    assume(np.all(np.hypot(r, p[:, 2]) < 0.98 * (L2 + L3)))  # inside the reach: an exact answer exists
    q_closed = leg_ik(p, (L1, L2, L3))
    assume(np.all(q_closed.reshape(-1) > ik.lo + 0.02) and np.all(q_closed.reshape(-1) < ik.hi - 0.02))
    targets = []
    for lg, tip in zip(hexapod.JETHEXA.legs(), p):
        R = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]]) if lg.side > 0 else np.diag([-1.0, -1.0, 1.0])
        targets.append(np.array(lg.hip) + R @ tip)
    result = ik.solve(np.array(targets)[None])
    assert result.err.max() < 1e-6
    np.testing.assert_allclose(ik.fk(q_closed.reshape(1, -1)), np.array(targets)[None], atol=1e-6)
    np.testing.assert_allclose(result.q.reshape(6, 3), q_closed, atol=1e-5)
    assert math.isfinite(float(result.err.max()))

"""One damage vocabulary (app/robots/damage.py) for every robot with a leg map: each type is
made by one function on the built-in hexapod and on an uploaded robot alike, the paper's
leg numbers are a spelling of the leg map's names, and the older spelling (``DamageSpec``
by number) builds the very same models."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pydantic import ValidationError

sys.path.insert(0, str(Path(__file__).parent))
import legged_models as lm_  # noqa: E402

from app.jobs.recovery.spec import RecoverySpec  # noqa: E402
from app.robots.catalog import JETHEXA  # noqa: E402
from app.robots.damage import (Damage, DamageSpec, LockedJoint, LockedJointDamage, WeakJoint,  # noqa: E402
                               apply_damage)
from app.robots.detect import detect_legs  # noqa: E402
from app.robots.legmap import LegMapError, Robot  # noqa: E402
from app.robots.walkable import make_walkable  # noqa: E402

OBJ = mujoco.mjtObj


def _uploaded() -> Robot:
    spec = lm_.build(lm_.HEXAPOD_OTHER)
    return Robot("hexapod_other", spec.to_xml(), {}, detect_legs(spec.compile()))


def _id(m: mujoco.MjModel, obj, name: str) -> int:
    return mujoco.mj_name2id(m, obj, name)


def test_the_papers_numbers_are_a_spelling_of_the_leg_maps_names():
    spec = RecoverySpec.parse({"kind": "recovery", "damage": {
        "lost_legs": [1, 6], "locked_joints": [{"leg": 2, "joint": "femur", "angle_deg": 20.0}],
        "weak_joints": [{"leg": 3, "joint": "tibia", "torque_scale": 0.25}]}})
    named = spec.damage.named()
    assert named.lost_legs == ["leg1", "leg6"]
    assert (named.locked_joints[0].leg, named.locked_joints[0].joint) == ("leg2", "leg2_femur")
    assert named.locked_joints[0].value == math.radians(20.0)
    assert (named.weak_joints[0].joint, named.weak_joints[0].torque_scale) == ("leg3_tibia", 0.25)
    legs = {l.name: l for l in JETHEXA.leg_map().legs}
    assert legs["leg2"].joints == ["leg2_coxa", "leg2_femur", "leg2_tibia"]  # the names the map gives


def test_every_spelling_builds_the_same_model():
    """The vocabulary, the numbered DamageSpec and the repertoire kind's damage (the vocabulary,
    its dump narrowed to the fields its specs always had): one model each time."""
    from app.jobs.repertoire.spec import Damage as RepertoireDamage

    by_name = Damage(lost_legs=["leg5"], locked_joints=[LockedJointDamage(leg="leg2", joint="leg2_femur",
                                                                          angle_deg=30.0)])
    by_number = DamageSpec(lost_legs=(5,), locked_joints=(LockedJoint(2, "femur", math.radians(30.0)),))
    assert JETHEXA.model(by_name)[0].to_xml() == JETHEXA.model(by_number)[0].to_xml()
    robot = _uploaded()
    a, b = robot.legs.legs[0], robot.legs.legs[1]
    given = {"lost_legs": [a.name], "passive_joints": [{"leg": b.name, "joint": b.joints[1]}],
             "shortened_legs": [{"leg": b.name, "length_m": 0.02}]}
    vocab, repertoire = Damage.model_validate(given), RepertoireDamage.model_validate(given)
    assert make_walkable(robot, repertoire).spec.to_xml() == make_walkable(robot, vocab).spec.to_xml()
    assert make_walkable(robot, vocab).spec.to_xml() != make_walkable(robot, Damage()).spec.to_xml()
    assert RepertoireDamage().model_dump() == {"lost_legs": [], "locked_joints": []}  # specs written before stay as they were
    assert repertoire.model_dump()["shortened_legs"] == [{"leg": b.name, "length_m": 0.02}]


def test_one_function_damages_the_built_in_and_an_uploaded_robot():
    """The same edit on both: lost leg, locked, weak and passive joints, through apply_damage."""
    robot = _uploaded()
    for legs, spec in ((JETHEXA.leg_map(), JETHEXA.build()), (robot.legs, robot.spec())):
        first, second, third = legs.legs[0], legs.legs[2], legs.legs[3]
        damage = Damage.model_validate({
            "lost_legs": [first.name],
            "locked_joints": [{"leg": second.name, "joint": second.joints[-1]}],
            "passive_joints": [{"leg": third.name, "joint": third.joints[0]}],
            "weak_joints": [{"leg": third.name, "joint": third.joints[1], "torque_scale": 0.5}]})
        if not list(spec.actuators):  # the upload has no servos of its own here: give every joint one
            for j in legs.joint_names():
                spec.add_actuator(name=f"{j}_servo", target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                  forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE, forcerange=[-2.0, 2.0])
        before = {a.target: list(a.forcerange) for a in spec.actuators}
        apply_damage(spec, legs, damage)
        m = spec.compile()
        driven = {mujoco.mj_id2name(m, OBJ.mjOBJ_JOINT, int(m.actuator_trnid[a, 0])): a for a in range(m.nu)}
        assert not any(j in driven or _id(m, OBJ.mjOBJ_JOINT, j) >= 0 for j in first.joints)  # lost: gone
        assert _id(m, OBJ.mjOBJ_JOINT, second.joints[-1]) == -1 and second.joints[-1] not in driven  # welded
        assert _id(m, OBJ.mjOBJ_JOINT, third.joints[0]) >= 0 and third.joints[0] not in driven  # passive
        np.testing.assert_allclose(m.actuator_forcerange[driven[third.joints[1]]],
                                   0.5 * np.asarray(before[third.joints[1]]))


def test_a_passive_joint_on_the_built_in_hexapod_has_no_actuator_force_and_the_robot_simulates():
    """The issue's worked example: a passive joint on the built-in hexapod, from the vocabulary
    alone. Its servo is gone, the joint stays and swings under gravity with no actuator force
    while every other servo holds; the robot still steps without a warning."""
    damage = Damage.model_validate({"passive_joints": [{"leg": "leg2", "joint": "leg2_femur"}]})
    _, m = JETHEXA.model(damage)
    _, intact = JETHEXA.model()
    assert m.nu == intact.nu - 1 and m.njnt == intact.njnt
    d = mujoco.MjData(m)
    d.qpos[3] = 1.0
    free, held = _id(m, OBJ.mjOBJ_JOINT, "leg2_femur"), _id(m, OBJ.mjOBJ_JOINT, "leg1_femur")
    m.opt.gravity[:] = 0.0
    d.qvel[m.jnt_dofadr[free]] = d.qvel[m.jnt_dofadr[held]] = 1.0  # both knocked upward; the servo pulls back
    d.ctrl[:] = 0.0
    for _ in range(300):
        mujoco.mj_step(m, d)
        assert d.qfrc_actuator[m.jnt_dofadr[free]] == 0.0
    assert np.all(np.isfinite(d.qpos)) and not any(w.number for w in d.warning)
    assert abs(d.qpos[m.jnt_qposadr[held]]) < 0.05  # the servo brought its joint back
    assert d.qpos[m.jnt_qposadr[free]] > 0.2  # nothing brought the passive one back


def test_a_shortened_leg_on_the_built_in_hexapod_moves_its_foot_back():
    cut = 0.03
    _, intact = JETHEXA.model()
    _, m = JETHEXA.model(Damage.model_validate({"shortened_legs": [{"leg": "leg4", "length_m": cut}]}))
    tip = _id(intact, OBJ.mjOBJ_SITE, "leg4_tip")
    assert np.linalg.norm(m.site_pos[tip] - intact.site_pos[tip]) == pytest.approx(cut)
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos))


def test_the_vocabulary_names_what_does_not_fit():
    legs = JETHEXA.leg_map()
    with pytest.raises(LegMapError, match=r"lost_legs: no leg 'leg7'"):
        Damage(lost_legs=["leg7"]).check(legs)
    with pytest.raises(LegMapError, match=r"leg 'leg1' has no joint 'coxa'"):
        Damage.model_validate({"weak_joints": [{"leg": "leg1", "joint": "coxa"}]}).check(legs)
    with pytest.raises(ValidationError, match="joint 'leg1_coxa' of leg 'leg1' is damaged twice"):
        Damage.model_validate({"locked_joints": [{"leg": "leg1", "joint": "leg1_coxa"}],
                               "passive_joints": [{"leg": "leg1", "joint": "leg1_coxa"}]})
    with pytest.raises(ValidationError, match="each leg may be listed once"):
        Damage(lost_legs=["leg1", "leg1"])
    with pytest.raises(ValidationError, match="greater than 0"):
        Damage.model_validate({"weak_joints": [{"leg": "leg1", "joint": "leg1_coxa", "torque_scale": 0.0}]})
    with pytest.raises(ValidationError, match="valid string"):  # strict: no coercion
        Damage.model_validate({"lost_legs": [1]})
    assert WeakJoint(1, "coxa", 0.5) == WeakJoint(1, "coxa", 0.5)  # the numbered spelling stays a value


def _coxae_after(damage: Damage, steps: int) -> tuple[float, float]:
    """leg1's and leg2's coxa angles ``steps`` steps after both servos are told 0.3 rad (no gravity)."""
    _, m = JETHEXA.model(damage)
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    d.qpos[3] = 1.0
    for leg in ("leg1", "leg2"):
        d.ctrl[_id(m, OBJ.mjOBJ_ACTUATOR, f"{leg}_coxa_pid")] = 0.3
    for _ in range(steps):
        mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos)) and not any(w.number for w in d.warning)
    return tuple(float(d.qpos[m.jnt_qposadr[_id(m, OBJ.mjOBJ_JOINT, f"{leg}_coxa")]]) for leg in ("leg1", "leg2"))


def test_a_stiff_joint_resists_its_servo_on_every_robot_with_legs():
    """The damage type added as the worked example (issue 42): dry friction in a joint. On the
    built-in hexapod a coxa whose friction (5 N*m) exceeds its servo's torque (3.4 N*m) only
    creeps toward its set-point while the intact one gets there; a friction below the servo's
    torque is overcome. An uploaded robot takes it by name, and the recovery spec's
    robot_damage (the vocabulary itself) accepts it with no change of its own."""
    stiff = Damage.model_validate({"stiff_joints": [{"leg": "leg1", "joint": "leg1_coxa", "friction": 5.0}]})
    _, m = JETHEXA.model(stiff)
    assert m.dof_frictionloss[m.jnt_dofadr[_id(m, OBJ.mjOBJ_JOINT, "leg1_coxa")]] == 5.0
    held, free = _coxae_after(stiff, 200)
    assert free > 0.2 and held < 0.15
    light = Damage.model_validate({"stiff_joints": [{"leg": "leg1", "joint": "leg1_coxa", "friction": 1.0}]})
    assert _coxae_after(light, 500)[0] == pytest.approx(0.3, abs=0.01)
    robot = _uploaded()
    leg = robot.legs.legs[2]
    spec = RecoverySpec.parse({"kind": "recovery", "robot": "ab" * 16, "robot_damage": {
        "stiff_joints": [{"leg": leg.name, "joint": leg.joints[1], "friction": 0.5}]}})
    w = make_walkable(robot, spec.robot_damage, timestep=0.001)
    wm = w.spec.compile()
    j = _id(wm, OBJ.mjOBJ_JOINT, leg.joints[1])
    assert wm.dof_frictionloss[wm.jnt_dofadr[j]] == 0.5 and _id(wm, OBJ.mjOBJ_ACTUATOR, f"{leg.joints[1]}_servo") >= 0
    with pytest.raises(ValidationError, match="is damaged twice"):
        Damage.model_validate({"stiff_joints": [{"leg": "leg1", "joint": "leg1_coxa", "friction": 1.0}],
                               "passive_joints": [{"leg": "leg1", "joint": "leg1_coxa"}]})


def test_an_unused_later_type_leaves_no_trace_in_a_dump():
    """Specs and bundles written before a type was added dump byte-identical after it."""
    d = Damage.model_validate({"lost_legs": ["leg1"]})
    assert "stiff_joints" not in d.model_dump(mode="json")
    assert Damage.model_validate(d.model_dump(mode="json")) == d
    stiff = {"stiff_joints": [{"leg": "leg1", "joint": "leg1_coxa", "friction": 2.0}]}
    assert Damage.model_validate(stiff).model_dump(mode="json")["stiff_joints"] == stiff["stiff_joints"]


def test_every_damage_type_has_its_words_and_every_kind_says_them():
    """``Damage.describe`` words every type (a type added without its words fails here), and
    the kinds that take the vocabulary show it whole: a weak, passive, stiff or shortened
    damage is never reported as "none"."""
    from app.jobs.registry import get_kind
    from app.robots.damage import ShortenedLegDamage, StiffJointDamage, WeakJointDamage

    assert set(Damage.WORDS) == set(Damage.model_fields)
    d = Damage(lost_legs=["leg1"], locked_joints=[LockedJointDamage(leg="leg2", joint="leg2_femur", angle_deg=-40.0)],
               weak_joints=[WeakJointDamage(leg="leg3", joint="leg3_coxa", torque_scale=0.2)],
               passive_joints=[{"leg": "leg4", "joint": "leg4_tibia"}],
               shortened_legs=[ShortenedLegDamage(leg="leg5", length_m=0.02)],
               stiff_joints=[StiffJointDamage(leg="leg6", joint="leg6_femur", friction=0.5)])
    words = ("lost leg1; locked leg2_femur at -40 deg; weak leg3_coxa at 20 % force; passive leg4_tibia; "
             "shortened leg5 by 2 cm; stiff leg6_femur (friction 0.5)")
    assert d.describe() == words and Damage().describe() == "none"
    kind = get_kind("repertoire")
    assert kind.damage_text(kind.Spec.parse({"kind": "repertoire", "damage": d.model_dump()})) == words
    only_weak = {"kind": "repertoire", "damage": {"weak_joints": [{"leg": "leg3", "joint": "leg3_coxa",
                                                                   "torque_scale": 0.2}]}}
    assert kind.damage_text(kind.Spec.parse(only_weak)) == "weak leg3_coxa at 20 % force"

"""Damage: ONE vocabulary for every robot with a leg map, by the map's names, and ONE
function that makes it in a robot's model (``apply_damage``).

A robot model here is an MjSpec whose leg joints (the leg map's) are each driven by one
actuator whose target is the joint: the built-in hexapod's ``<joint>_pid`` servos
(app/robots/catalog.py), an uploaded robot's ``<joint>_servo`` (app/robots/walkable.py adds
them before the damage). Each damage type is defined once, below: its entry in the
vocabulary (``Damage``'s field), its check against the leg map and its edit of the model.

- **lost leg**: the whole leg subtree is deleted (from the first body of its chain: its
  mass, inertia and actuators go too);
- **locked joint**: the joint is deleted and its body turned (hinge) or moved (slide) to
  the held value about the joint's anchor, an exact weld (no stiff spring for the solver to
  fight); its actuator goes;
- **weak joint**: its actuator's force limit is scaled down;
- **passive joint**: its actuator goes; the joint stays, with its damping, and swings freely;
- **shortened leg**: the foot segment (its last joint to its foot) is cut by a length;
- **stiff joint**: dry friction is added in the joint (a worn gearbox or a seized bearing
  that its servo must overcome; MuJoCo's ``frictionloss``).

Adding a damage type: its entry model and a field on ``Damage`` (left out of a dump while
unused: ``Damage.ALWAYS``) with its words (``Damage.WORDS``), its name in ``JOINT_FIELDS``
if it names joints (checked against the map, once per joint), and its edit in
``apply_damage``; every kind whose spec takes ``Damage`` (or a subclass) then offers it on
every robot (recovery through ``robot_damage``, the built-in hexapod's too). ``stiff_joints``
was added so (issue 42): this module and its test, tests/robots/test_damage_vocabulary.py.

Legs are named by their map: the built-in hexapod's are ``leg1``..``leg6`` with joints
``leg<n>_coxa``/``_femur``/``_tibia`` (app/robots/hexapod/__init__.py ``leg_map``). The
paper's leg numbers are a spelling of those names, translated where a spec takes them (the
recovery spec's ``Damage.named``); ``DamageSpec`` below is that spelling for code that
still builds a damaged hexapod by number.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Annotated, ClassVar

import mujoco
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, model_serializer, model_validator

from app.robots.hexapod import joint_name, leg_name
from app.robots.legmap import Foot, Leg, LegMap, LegMapError

OBJ = mujoco.mjtObj

# A leg or joint by the leg map's name: any printable text, bounded (as MJCF names are).
MapName = Annotated[str, Field(min_length=1, max_length=128, pattern=r"^[^\x00-\x1f\x7f]+$")]
# What a spec section is: strict (no coercion), unknown fields refused, finite numbers only
# (the jobs' StrictModel, which this layer may not import).
STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class _Entry(BaseModel):
    model_config = STRICT


# -- the vocabulary --------------------------------------------------------------------------

class JointDamage(_Entry):  # a joint of a leg, by the leg map's names (a passive joint is just that)
    leg: MapName
    joint: MapName


class LockedJointDamage(JointDamage):
    angle_deg: float = Field(0.0, ge=-180.0, le=180.0, description="the joint's value it is held at (a slide "
                                                                     "joint: 0, held at its reference)")
    _value: float | None = PrivateAttr(None)  # the held value in the joint's unit, when given so (held_at)

    @property
    def value(self) -> float:
        """The held value in the joint's unit: rad (a slide joint: m)."""
        return math.radians(self.angle_deg) if self._value is None else self._value

    @classmethod
    def held_at(cls, leg: str, joint: str, value: float) -> LockedJointDamage:
        """Locked at ``value`` in the joint's unit (rad, m), kept exactly as given."""
        out = cls.model_construct(leg=leg, joint=joint, angle_deg=float(math.degrees(value)))  # checked by its caller
        out._value = float(value)
        return out


class WeakJointDamage(JointDamage):
    torque_scale: float = Field(0.5, gt=0.0, le=1.0)


class StiffJointDamage(JointDamage):
    friction: float = Field(gt=0.0, le=100.0, description="dry friction added in the joint: N*m (a slide joint: N)")


class ShortenedLegDamage(_Entry):
    leg: MapName
    length_m: float = Field(gt=0.0, le=1.0, description="cut from the foot segment (its last joint to its foot), "
                                                        "at most 80 % of it")


JOINT_FIELDS = ("locked_joints", "weak_joints", "passive_joints", "stiff_joints")  # each names (leg, joint) pairs


def damaged_once(damage, fields: tuple[str, ...], show) -> None:
    """Every joint damage on a leg that is not lost, and no joint damaged twice; ``show``
    writes a leg or joint in the message (numbers as they are: ``str``, names quoted: ``repr``)."""
    seen = set()
    for name in fields:
        for j in getattr(damage, name):
            if j.leg in damage.lost_legs:
                raise ValueError(f"{name}: leg {show(j.leg)} is listed as lost")
            if (j.leg, j.joint) in seen:
                raise ValueError(f"{name}: joint {show(j.joint)} of leg {show(j.leg)} is damaged twice")
            seen.add((j.leg, j.joint))


class Damage(_Entry):
    """A robot's damage by its leg map's names: lost legs, locked joints, weak joints
    (servo force limit scaled), passive joints (no servo: the joint swings freely with its
    damping), shortened legs (the foot segment cut by a length) and stiff joints (dry
    friction added). ``{}``: intact."""

    lost_legs: list[MapName] = Field(default_factory=list, max_length=16)
    locked_joints: list[LockedJointDamage] = Field(default_factory=list, max_length=128)
    weak_joints: list[WeakJointDamage] = Field(default_factory=list, max_length=128)
    passive_joints: list[JointDamage] = Field(default_factory=list, max_length=128)
    shortened_legs: list[ShortenedLegDamage] = Field(default_factory=list, max_length=16)
    stiff_joints: list[StiffJointDamage] = Field(default_factory=list, max_length=128)

    # The fields a dump always holds; any other only when it is used, so that the specs and
    # bundles written before a type was added (or before a kind took this vocabulary) stay
    # byte-identical. A kind's subclass may narrow it to the fields its specs always had.
    ALWAYS: ClassVar[tuple[str, ...]] = ("lost_legs", "locked_joints", "weak_joints", "passive_joints",
                                         "shortened_legs")
    # How each type reads in a sentence (``describe``: job lists, pages, videos), one entry a field.
    WORDS: ClassVar[dict] = {
        "lost_legs": lambda leg: f"lost {leg}",
        "locked_joints": lambda j: f"locked {j.joint} at {j.angle_deg:g} deg",
        "weak_joints": lambda j: f"weak {j.joint} at {100 * j.torque_scale:g} % force",
        "passive_joints": lambda j: f"passive {j.joint}",
        "shortened_legs": lambda l: f"shortened {l.leg} by {100 * l.length_m:g} cm",
        "stiff_joints": lambda j: f"stiff {j.joint} (friction {j.friction:g})",
    }

    @model_serializer(mode="wrap")
    def _used(self, handler):
        return {k: v for k, v in handler(self).items() if v or k in self.ALWAYS}

    @model_validator(mode="after")
    def _once(self):
        if len(set(self.lost_legs)) != len(self.lost_legs):
            raise ValueError("lost_legs: each leg may be listed once")
        short = [l.leg for l in self.shortened_legs]
        if len(set(short)) != len(short) or set(short) & set(self.lost_legs):
            raise ValueError("shortened_legs: each leg may be listed once, and not if it is lost")
        damaged_once(self, JOINT_FIELDS, repr)
        return self

    def check(self, legs: LegMap) -> None:
        """LegMapError naming the first leg or joint the map does not have."""
        names = {l.name: l for l in legs.legs}
        for what, items in (("lost_legs", self.lost_legs), ("shortened_legs", [l.leg for l in self.shortened_legs])):
            for leg in items:
                if leg not in names:
                    raise LegMapError(f"{what}: no leg {leg!r}; legs: {sorted(names)}")
                if what == "shortened_legs" and leg in self.lost_legs:
                    raise LegMapError(f"shortened_legs: leg {leg!r} is listed as lost")
        for what in JOINT_FIELDS:
            for j in getattr(self, what):
                if j.leg not in names:
                    raise LegMapError(f"{what}: no leg {j.leg!r}; legs: {sorted(names)}")
                if j.joint not in names[j.leg].joints:
                    raise LegMapError(f"{what}: leg {j.leg!r} has no joint {j.joint!r}; its joints: "
                                      f"{names[j.leg].joints}")
                if j.leg in self.lost_legs:
                    raise LegMapError(f"{what}: leg {j.leg!r} is listed as lost")

    def describe(self, intact: str = "none") -> str:
        """Every damage in words, in the vocabulary's order ("lost leg3; locked leg2_femur at
        10 deg"); ``intact`` when there is none."""
        return "; ".join(self.WORDS[f](item) for f in type(self).model_fields for item in getattr(self, f)) or intact

    def locked(self) -> dict[str, float]:
        """Locked joint -> its held value (rad, m)."""
        return {j.joint: j.value for j in self.locked_joints}

    def passive(self) -> set[str]:
        return {j.joint for j in self.passive_joints}


# -- the edits -------------------------------------------------------------------------------

@dataclasses.dataclass
class Applied:
    """What the damage changed that the robot's owner reads back: each shortened leg's foot
    (its body and the new foot point in that body's frame)."""

    feet: dict[str, tuple[str, list[float]]] = dataclasses.field(default_factory=dict)


def apply_damage(spec: mujoco.MjSpec, legs: LegMap, damage: Damage, rest: mujoco.MjModel | None = None) -> Applied:
    """Make ``damage`` in ``spec`` (mutated) of the robot with leg map ``legs``; LegMapError
    names what does not fit. ``rest``: the intact robot compiled (a shortened leg is cut at
    its reference pose); compiled from ``spec`` here when a leg is shortened and none is given."""
    damage.check(legs)
    if damage.shortened_legs and rest is None:
        name_parts(spec)
        rest = spec.compile()
    for name in damage.lost_legs:
        _lose(spec, legs, legs.leg(name))
    for j in damage.locked_joints:
        _unpower(spec, j.joint)
        _lock(spec, j.joint, j.value)
    for j in damage.passive_joints:
        _unpower(spec, j.joint)
    for j in damage.weak_joints:
        for act in _actuators(spec, {j.joint}):
            act.forcerange = [v * j.torque_scale for v in act.forcerange]
    for j in damage.stiff_joints:
        joint = spec.joint(j.joint)
        joint.frictionloss = float(joint.frictionloss) + j.friction
    out = Applied()
    for s in damage.shortened_legs:
        out.feet[s.leg] = _shorten(spec, rest, legs, legs.leg(s.leg), s.length_m)
    return out


def _actuators(spec: mujoco.MjSpec, joints: set[str]) -> list:
    return [a for a in spec.actuators if a.target in joints]


def _unpower(spec: mujoco.MjSpec, joint: str) -> None:
    for act in _actuators(spec, {joint}):
        spec.delete(act)


def _subtree_joints(body) -> set[str]:
    return {j.name for j in body.joints} | {n for b in body.bodies for n in _subtree_joints(b)}


def first_body(spec: mujoco.MjSpec, legs: LegMap, leg: Leg):
    """The leg's first body: the trunk's child on the way to its first joint."""
    body = spec.joint(leg.joints[0]).parent
    while body.parent.name != legs.trunk:
        if body.parent.name == spec.worldbody.name:
            raise LegMapError(f"leg {leg.name!r}: its joints are not below the trunk {legs.trunk!r}")
        body = body.parent
    return body


def _lose(spec: mujoco.MjSpec, legs: LegMap, leg: Leg) -> None:
    body = first_body(spec, legs, leg)
    for act in _actuators(spec, _subtree_joints(body)):
        spec.delete(act)
    spec.delete(body)


def _lock(spec: mujoco.MjSpec, joint_name: str, value: float) -> None:
    """Delete the joint and weld its body at ``value`` (rad or m from the joint's reference)."""
    j = spec.joint(joint_name)
    body = j.parent
    if len(body.joints) != 1:
        raise LegMapError(f"locked_joints: joint {joint_name!r} shares its body with other joints; "
                          "only a joint alone on its body can be locked")
    axis = np.asarray(j.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(body.quat, dtype=float))
    R = R.reshape(3, 3)
    delta = value - float(j.ref)
    if j.type == mujoco.mjtJoint.mjJNT_SLIDE:
        if value != 0.0:
            raise LegMapError(f"locked_joints: {joint_name!r} is a slide joint: it is held at its reference "
                              "(angle_deg 0)")
        delta = 0.0
        body.pos = np.asarray(body.pos, dtype=float) + R @ (axis * delta)
    else:
        rot = np.concatenate([[math.cos(delta / 2)], math.sin(delta / 2) * axis])
        Rj = np.zeros(9)
        mujoco.mju_quat2Mat(Rj, rot)
        anchor = np.asarray(j.pos, dtype=float)
        body.pos = np.asarray(body.pos, dtype=float) + R @ (anchor - Rj.reshape(3, 3) @ anchor)
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, np.asarray(body.quat, dtype=float), rot)
        body.quat = q
    spec.delete(j)


def name_parts(spec: mujoco.MjSpec) -> None:
    """Edits name their bodies and geoms: an unnamed one gets a name (gm_body<k>, gm_geom<k>)."""
    for k, b in enumerate(spec.bodies):
        if not b.name:
            b.name = f"gm_body{k}"
    for k, g in enumerate(spec.geoms):
        if not g.name:
            g.name = f"gm_geom{k}"


def foot_in_body(model: mujoco.MjModel, foot: Foot) -> tuple[str, list[float]]:
    """The foot's body and the foot point in that body's frame."""
    from app.robots.numik import _foot_in_body as local

    body, point = local(model, type("L", (), {"foot": foot})())
    return mujoco.mj_id2name(model, OBJ.mjOBJ_BODY, body), [float(v) for v in point]


def _shorten(spec: mujoco.MjSpec, model: mujoco.MjModel, legs: LegMap, leg: Leg, cut: float) -> tuple[str, list[float]]:
    """Cut ``cut`` metres from the leg's foot segment (from its last joint to its foot), at the
    reference pose of ``model`` (the intact robot): geoms and sites of the segment's bodies
    beyond the cut move back along it by ``cut``, a capsule or cylinder along it that reaches
    past the cut is shortened by ``cut``. Returns the foot's body and new point in it."""
    from app.robots.detect import _Kin, _path_to_trunk

    kin = _Kin.at_rest(model, mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk))
    foot = foot_in_body(model, leg.foot)
    j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, leg.joints[-1])
    body_f = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, foot[0])
    a, f = kin.data.xanchor[j].copy(), kin.data.xpos[body_f] + kin.data.xmat[body_f].reshape(3, 3) @ foot[1]
    length = float(np.linalg.norm(f - a))
    if not cut < 0.8 * length:
        raise LegMapError(f"shortened_legs: leg {leg.name!r}: its foot segment is {length:.3f} m; "
                          f"at most 80 % of it ({0.8 * length:.3f} m) can be cut")
    d = (f - a) / length
    bodies = [int(model.jnt_bodyid[j])] + [b for b in (_path_to_trunk(model, body_f, int(model.jnt_bodyid[j])) or [])]
    edge = length - cut
    for b in dict.fromkeys(bodies):
        R, x = kin.data.xmat[b].reshape(3, 3), kin.data.xpos[b]
        for g in range(model.ngeom):
            if model.geom_bodyid[g] != b:
                continue
            c, z = kin.data.geom_xpos[g], kin.data.geom_xmat[g].reshape(3, 3)[:, 2]
            along = (c - a) @ d
            shift, half = 0.0, float(model.geom_size[g, 1])
            long = model.geom_type[g] in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER))
            if long and abs(z @ d) > 0.9 and along + half > edge:
                half, shift = max(half - cut / 2, 1e-4), cut / 2
            elif along > edge:
                shift = cut
            if shift:
                sg = spec.geom(mujoco.mj_id2name(model, OBJ.mjOBJ_GEOM, g))  # every geom is named (name_parts)
                sg.fromto = [np.nan] * 6
                sg.pos, sg.quat = list(R.T @ (c - shift * d - x)), list(model.geom_quat[g])
                sg.size = [float(model.geom_size[g, 0]), half, float(model.geom_size[g, 2])]
        for i in range(model.nsite):
            if model.site_bodyid[i] == b and (kin.data.site_xpos[i] - a) @ d > edge:
                site = spec.site(mujoco.mj_id2name(model, OBJ.mjOBJ_SITE, i))
                if site is not None:
                    site.pos = list(R.T @ (kin.data.site_xpos[i] - cut * d - x))
    Rf, xf = kin.data.xmat[body_f].reshape(3, 3), kin.data.xpos[body_f]
    return foot[0], [float(v) for v in Rf.T @ (f - cut * d - xf)]


# -- the paper's spelling: the built-in hexapod's legs by number ---------------------------

@dataclasses.dataclass(frozen=True)
class LockedJoint:
    leg: int
    joint: str  # coxa, femur, tibia
    angle_rad: float


@dataclasses.dataclass(frozen=True)
class WeakJoint:
    leg: int
    joint: str
    torque_scale: float


@dataclasses.dataclass(frozen=True)
class DamageSpec:
    """The built-in hexapod's damage by leg number (the paper's spelling); ``named()`` is the
    one vocabulary's ``Damage``."""

    lost_legs: tuple[int, ...] = ()
    locked_joints: tuple[LockedJoint, ...] = ()
    weak_joints: tuple[WeakJoint, ...] = ()

    def named(self) -> Damage:
        return Damage(lost_legs=[leg_name(n) for n in self.lost_legs],
                      locked_joints=[LockedJointDamage.held_at(leg_name(j.leg), joint_name(j.leg, j.joint), j.angle_rad)
                                     for j in self.locked_joints],
                      weak_joints=[WeakJointDamage(leg=leg_name(j.leg), joint=joint_name(j.leg, j.joint),
                                                   torque_scale=float(j.torque_scale)) for j in self.weak_joints])

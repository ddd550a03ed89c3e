"""Damage applied to a robot's MjSpec, so each damaged robot is its own compiled model.

- lost legs: the whole leg subtree is deleted (its mass, inertia and actuators go too);
- locked joints: the hinge is deleted and its child body is rotated by the held angle,
  which is an exact weld (no stiff spring for the solver to fight);
- weak joints: the actuator's torque limit is scaled down.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from app.robots.hexapod import JOINT_NAMES, joint_name


@dataclasses.dataclass(frozen=True)
class LockedJoint:
    leg: int
    joint: str
    angle_rad: float


@dataclasses.dataclass(frozen=True)
class WeakJoint:
    leg: int
    joint: str
    torque_scale: float


@dataclasses.dataclass(frozen=True)
class DamageSpec:
    lost_legs: tuple[int, ...] = ()
    locked_joints: tuple[LockedJoint, ...] = ()
    weak_joints: tuple[WeakJoint, ...] = ()


def _axis_angle_quat(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def apply_damage(spec: mujoco.MjSpec, damage: DamageSpec) -> mujoco.MjSpec:
    """Mutates and returns spec."""
    for leg in damage.lost_legs:
        for jn in JOINT_NAMES:
            act = spec.actuator(f"{joint_name(leg, jn)}_pid")
            if act is not None:
                spec.delete(act)
        spec.delete(spec.body(f"leg{leg}_coxa"))
    for lock in damage.locked_joints:
        name = joint_name(lock.leg, lock.joint)
        joint = spec.joint(name)
        body = spec.body(f"leg{lock.leg}_{lock.joint}")
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, np.asarray(body.quat, dtype=float), _axis_angle_quat(joint.axis, lock.angle_rad))
        body.quat = q
        spec.delete(spec.actuator(f"{name}_pid"))
        spec.delete(joint)
    for weak in damage.weak_joints:
        act = spec.actuator(f"{joint_name(weak.leg, weak.joint)}_pid")
        act.forcerange = [v * weak.torque_scale for v in act.forcerange]
    return spec

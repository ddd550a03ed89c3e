"""Dummy legs (paper 003, Sec. I-B steps 4-5): the legs' joint paths when the trunk moves at
constant speed V and height h, and the force f_l and moment m_l they put on the trunk.

The wrench comes from MuJoCo's inverse dynamics of the whole model (real link masses and
inertias): with the trunk's acceleration zero, mj_inverse returns the free joint force that
holds the trunk on its path; less the trunk's own weight, what is left is what the legs
take from the trunk, so f_l, m_l are its negative. Moments are about the trunk CoM.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.energy.dynamics.gait import Gait, Task, feet_world
from app.jobs.energy.dynamics.whole_body import GRAVITY, WholeBody, periodic_derivatives


@dataclasses.dataclass
class LegMotion:
    t: np.ndarray  # (K,) knots over one period, end excluded
    feet: np.ndarray  # (K, 4, 3) world tip paths
    q: np.ndarray  # (K, 12)
    qd: np.ndarray
    qdd: np.ndarray
    reach_ok: np.ndarray  # (K, 4)


def nominal_body(task: Task, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r = np.zeros((len(t), 3))
    r[:, 0], r[:, 2] = task.speed * t, task.height
    return r, np.zeros((len(t), 3))


def leg_motion(wb: WholeBody, gait: Gait, task: Task, t: np.ndarray, r: np.ndarray, theta: np.ndarray) -> LegMotion:
    """Legs by IK against the world foot paths for a periodic trunk path r, theta on the
    knots ``t`` (K equal steps of T/K); joint rates by periodic finite differences."""
    feet = feet_world(gait, task, wb.geom, t)
    q, ok = wb.leg_angles(r, theta, feet)
    qd, qdd = periodic_derivatives(q, gait.period / len(t))
    return LegMotion(t=t, feet=feet, q=q, qd=qd, qdd=qdd, reach_ok=ok)


def dummy_leg_wrench(wb: WholeBody, gait: Gait, task: Task, n_knots: int) -> tuple[LegMotion, np.ndarray, np.ndarray]:
    """(motion, f_l (K, 3) world, m_l (K, 3) about the trunk CoM) on K = n_knots knots."""
    t = np.arange(n_knots) * gait.period / n_knots
    r, theta = nominal_body(task, t)
    legs = leg_motion(wb, gait, task, t, r, theta)
    v = np.zeros((n_knots, 3))
    v[:, 0] = task.speed
    qpos = wb.qpos(r, theta, legs.q)
    qvel = wb.qvec(v, np.zeros_like(v), legs.qd)
    qacc = wb.qvec(np.zeros_like(v), np.zeros_like(v), legs.qdd)
    qfrc, _, _ = wb.inverse(qpos, qvel, qacc)
    trunk_hold = np.array([0.0, 0.0, wb.geom.trunk_mass * GRAVITY])
    return legs, -(qfrc[:, :3] - trunk_hold), -qfrc[:, 3:6]

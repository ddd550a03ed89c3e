"""Batched numerical inverse kinematics for legs of any joint layout.

Damped least squares on MuJoCo's kinematics of the model: each leg's chain (the bodies
from the trunk to its foot with their compiled offsets, orientations, joint axes and
anchors, read from the MjModel) is evaluated the way ``mj_kinematics`` does it (a hinge
turns about its anchor by q - qpos0, a slide moves along its axis), vectorised over every
problem at once; each joint's Jacobian column is the one ``mj_jac`` gives (hinge: axis x
(foot - anchor), slide: axis). A population's targets for a whole gait period,
(P, T, legs, 3), are solved together: a loop over legs and joints of a chain, never over
candidates or samples; problems that have converged drop out of the batch.

Why not ``mj_kinematics`` itself over the population: a model holding many copies of the
legs compiles in time quadratic in its bodies (256 copies of the JetHexa's legs 3.6 s,
1024 copies 49 s, MuJoCo 4.0), and one call per problem is a Python loop. The transcribed
kinematics is checked against MuJoCo's at construction (the full model's ``mj_kinematics``
at the stance and at random poses, 1e-9 m) and in tests (``mj_jacSite``).

Targets are foot positions in the trunk's frame. The model's joint limits are kept (each
step is clipped to the range); the step is damped Levenberg-Marquardt style by
mu = damping * |error|^2 (+ a floor of (1e-6 reach)^2), which vanishes at a solution and so
keeps Newton's fast finish even near a singular pose, and capped at `max_step` per joint.
An unreachable target ends at the nearest point the iteration finds and `err` says how far
that is: every answer's error comes from forward kinematics of the answer itself.

This module reads the chains from the MjModel and checks them; the kinematics and the
solver are app/robots/chain_ik.py's (numpy only: the file a recovery bundle's controller
ships, so a robot solves as the simulation did).
"""

from __future__ import annotations

import mujoco
import numpy as np

from app.robots.chain_ik import ChainIK, LegChain
from app.robots.detect import _path_to_trunk
from app.robots.legmap import LegMap, LegMapError

OBJ = mujoco.mjtObj


def _quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v, dtype=float), np.asarray(q, dtype=float))
    return out


def _foot_in_body(model: mujoco.MjModel, leg) -> tuple[int, np.ndarray]:
    f = leg.foot
    off = np.asarray(f.offset, dtype=float)
    if f.kind == "body":
        return mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, f.name), off
    if f.kind == "geom":
        g = mujoco.mj_name2id(model, OBJ.mjOBJ_GEOM, f.name)
        return int(model.geom_bodyid[g]), model.geom_pos[g] + _quat_rotate(model.geom_quat[g], off)
    s = mujoco.mj_name2id(model, OBJ.mjOBJ_SITE, f.name)
    return int(model.site_bodyid[s]), model.site_pos[s] + _quat_rotate(model.site_quat[s], off)


def _leg_ranges(model: mujoco.MjModel, legs: LegMap) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    lo, hi, ref, types = [], [], [], []
    for leg in legs.legs:
        for k, name in enumerate(leg.joints):
            j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, name)
            if j < 0:
                raise LegMapError(f"leg {leg.name!r}: no joint named {name!r}")
            limited = bool(model.jnt_limited[j])
            lo.append(model.jnt_range[j, 0] if limited else -np.inf)
            hi.append(model.jnt_range[j, 1] if limited else np.inf)
            ref.append(leg.stance[k] if leg.stance is not None else model.qpos0[model.jnt_qposadr[j]])
            types.append(int(model.jnt_type[j]))
    return np.array(lo), np.array(hi), np.array(ref), np.array(types)



def _mat(q: np.ndarray) -> np.ndarray:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(q, dtype=float))
    return out.reshape(3, 3)


def _leg_chain(model: mujoco.MjModel, trunk: int, leg) -> LegChain:
    body, point = _foot_in_body(model, leg)
    path = _path_to_trunk(model, body, trunk) if body >= 0 else None
    if path is None:
        raise LegMapError(f"leg {leg.name!r}: its foot is not below the trunk")
    bodies = []
    for b in path:
        js = [(int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE), model.jnt_axis[j].copy(),
               model.jnt_pos[j].copy(), float(model.qpos0[model.jnt_qposadr[j]]))
              for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])]
        bodies.append((model.body_pos[b].copy(), _mat(model.body_quat[b]), js))
    if sum(len(js) for *_, js in bodies) != len(leg.joints):
        raise LegMapError(f"leg {leg.name!r}: its joints must be every joint from the trunk to its foot")
    return LegChain(bodies, np.asarray(point, dtype=float))


class LegIK(ChainIK):
    """Solves foot targets for every leg of `legs` on `model` (see the module doc): the
    chains read from the model, the solver app/robots/chain_ik.py's."""

    def __init__(self, model: mujoco.MjModel, legs: LegMap, damping: float = 0.1, max_step: float = 0.5):
        trunk = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk)
        if trunk < 0:
            raise LegMapError(f"trunk: no body named {legs.trunk!r}")
        for name in legs.joint_names():
            j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, name)
            if j >= 0 and int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                raise LegMapError(f"joint {name!r} is not a hinge or slide joint")
        self.legs = legs
        lo, hi, q_ref, _ = _leg_ranges(model, legs)
        chains = [_leg_chain(model, trunk, leg) for leg in legs.legs]
        super().__init__(chains, lo, hi, q_ref, np.zeros(len(chains)), damping, max_step)
        rest = self.fk(self.q_ref)
        hips = np.array([c.kinematics(self.q_ref[None, s])[2][0, 0] for c, s in zip(self.chains, self.cols)])
        self.rest_feet = rest
        self.floor = (1e-6 * np.maximum(np.linalg.norm(rest - hips, axis=-1), 1e-3)) ** 2  # (legs,), m^2
        self._check_against_mujoco(model, trunk)

    def _check_against_mujoco(self, model: mujoco.MjModel, trunk: int) -> None:
        """The transcribed kinematics must put every foot where mj_kinematics does."""
        from app.robots.detect import _Kin

        rng = np.random.default_rng(0)
        lo = np.where(np.isfinite(self.lo), self.lo, self.q_ref - 1.0)
        hi = np.where(np.isfinite(self.hi), self.hi, self.q_ref + 1.0)
        poses = np.stack([self.q_ref, *rng.uniform(lo, hi, (2, self.nq))])
        kin = _Kin(model, mujoco.MjData(model), trunk)
        adr = [model.jnt_qposadr[mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, n)] for n in self.legs.joint_names()]
        ours = self.fk(poses)
        for q, feet in zip(poses, ours):
            kin.data.qpos[:] = model.qpos0
            kin.data.qpos[adr] = q
            mujoco.mj_kinematics(model, kin.data)
            theirs = np.array([kin.local(kin.foot_point(leg.foot)) for leg in self.legs.legs])
            gap = float(np.abs(theirs - feet).max())
            if gap > 1e-9:
                raise RuntimeError(f"leg kinematics disagree with mj_kinematics by {gap:.3g} m")

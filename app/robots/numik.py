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
keeps Newton's fast finish even near a singular pose, and capped at `max_step` per joint. An unreachable target ends at the nearest point the
iteration finds and `err` says how far that is: every answer's error comes from forward
kinematics of the answer itself.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from app.robots.detect import _path_to_trunk
from app.robots.legmap import LegMap, LegMapError

OBJ = mujoco.mjtObj


@dataclasses.dataclass(frozen=True)
class IKResult:
    q: np.ndarray  # (..., nq): every leg joint, legs in map order (LegMap.joint_names())
    err: np.ndarray  # (..., legs): distance from each foot to its target after solving, m
    iterations: int  # the most any batch needed

    def reached(self, tol: float = 1e-6) -> np.ndarray:
        return self.err <= tol


@dataclasses.dataclass(frozen=True)
class _Body:
    pos: np.ndarray
    quat: np.ndarray
    joints: list[tuple[int, np.ndarray, np.ndarray]]  # (type, axis, pos) in the body frame


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


def _chain(model: mujoco.MjModel, trunk: int, leg) -> tuple[list[_Body], np.ndarray]:
    """The bodies from the trunk to the leg's foot, and the foot point in the last one."""
    body, point = _foot_in_body(model, leg)
    path = _path_to_trunk(model, body, trunk)
    if body < 0 or path is None:
        raise LegMapError(f"leg {leg.name!r}: its foot is not below the trunk")
    out = []
    for b in path:
        js = [(int(model.jnt_type[j]), model.jnt_axis[j].copy(), model.jnt_pos[j].copy())
              for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])]
        out.append(_Body(model.body_pos[b].copy(), model.body_quat[b].copy(), js))
    return out, point


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


def _skew(axis: np.ndarray) -> np.ndarray:
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _rm(R: np.ndarray, M: np.ndarray) -> np.ndarray:
    """R[n] @ M for a stack R (N, 3, 3) and one matrix or vector M: one BLAS call."""
    return (R.reshape(-1, 3) @ M).reshape(R.shape[0], 3, *M.shape[1:])


@dataclasses.dataclass(frozen=True)
class _LegChain:
    """One leg, in the terms mj_kinematics uses: per body its offset and rotation in its
    parent, per joint (type, unit axis, anchor in the body, qpos0); the foot in the last body."""

    bodies: list[tuple[np.ndarray, np.ndarray, list[tuple[bool, np.ndarray, np.ndarray, float]]]]
    foot: np.ndarray

    def kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Foot (N, 3), joint axes and anchors (N, K, 3) at joint values q (N, K), trunk frame."""
        n = len(q)
        R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        t = np.zeros((n, 3))
        axes, anchors, k = [], [], 0
        for pos, rot, joints in self.bodies:
            t = t + _rm(R, pos)
            R = _rm(R, rot)
            for hinge, axis, anchor, q0 in joints:
                a_w = _rm(R, axis)
                c_w = t + _rm(R, anchor)
                axes.append(a_w)
                anchors.append(c_w)
                if hinge:  # R Rot(axis, th) = R + sin(th) R K + (1 - cos(th)) R K^2 (Rodrigues)
                    K = _skew(axis)
                    th = (q[:, k] - q0)[:, None, None]
                    R = R + np.sin(th) * _rm(R, K) + (1.0 - np.cos(th)) * _rm(R, K @ K)
                    t = c_w - _rm(R, anchor)
                else:
                    t = t + a_w * (q[:, k] - q0)[:, None]
                k += 1
        return t + _rm(R, self.foot), np.stack(axes, axis=1), np.stack(anchors, axis=1)


def _leg_chain(model: mujoco.MjModel, trunk: int, leg) -> _LegChain:
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
    return _LegChain(bodies, np.asarray(point, dtype=float))


class LegIK:
    """Solves foot targets for every leg of `legs` on `model` (see the module doc)."""

    def __init__(self, model: mujoco.MjModel, legs: LegMap, damping: float = 0.1, max_step: float = 0.5):
        trunk = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk)
        if trunk < 0:
            raise LegMapError(f"trunk: no body named {legs.trunk!r}")
        for name in legs.joint_names():
            j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, name)
            if j >= 0 and int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                raise LegMapError(f"joint {name!r} is not a hinge or slide joint")
        self.legs = legs
        self.lo, self.hi, self.q_ref, _ = _leg_ranges(model, legs)
        self.chains = [_leg_chain(model, trunk, leg) for leg in legs.legs]
        self.nq, self.nlegs = len(self.q_ref), len(legs.legs)
        starts = np.cumsum([0] + [len(l.joints) for l in legs.legs])
        self.cols = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        self.max_step = float(max_step)
        rest = self.fk(self.q_ref)
        hips = np.array([c.kinematics(self.q_ref[None, s])[2][0, 0] for c, s in zip(self.chains, self.cols)])
        self.rest_feet = rest
        self.damping = float(damping)
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

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Feet (..., legs, 3) in the trunk frame for joint values q (..., nq)."""
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, self.nq)
        feet = np.stack([c.kinematics(flat[:, s])[0] for c, s in zip(self.chains, self.cols)], axis=1)
        return feet.reshape(*q.shape[:-1], self.nlegs, 3)

    def jacobian(self, q: np.ndarray, leg: int) -> tuple[np.ndarray, np.ndarray]:
        """One leg's foot (N, 3) and position Jacobian (N, 3, K) at its joint values q (N, K)."""
        chain = self.chains[leg]
        foot, axes, anchors = chain.kinematics(q)
        hinge = np.array([h for *_, js in chain.bodies for h, *_ in js])
        cols = np.where(hinge[None, :, None], np.cross(axes, foot[:, None, :] - anchors), axes)
        return foot, np.swapaxes(cols, 1, 2)

    def _solve_leg(self, leg: int, target: np.ndarray, q: np.ndarray, tol: float, max_iter: int) -> tuple[np.ndarray, int]:
        s = self.cols[leg]
        lo, hi = self.lo[s], self.hi[s]
        active = np.arange(len(q))
        it = 0
        for it in range(1, max_iter + 1):
            foot, J = self.jacobian(q[active], leg)
            e = target[active] - foot
            norm = np.linalg.norm(e, axis=-1)
            done = norm <= tol
            active, J, e, norm = active[~done], J[~done], e[~done], norm[~done]
            if not len(active):
                break
            mu = self.damping * norm**2 + self.floor[leg]  # Levenberg-Marquardt: vanishes at a solution
            A = J @ np.swapaxes(J, 1, 2) + mu[:, None, None] * np.eye(3)
            dq = (np.swapaxes(J, 1, 2) @ np.linalg.solve(A, e[..., None]))[..., 0]
            big = np.abs(dq).max(axis=-1, keepdims=True)
            dq *= np.minimum(1.0, self.max_step / np.maximum(big, 1e-300))
            q[active] = np.clip(q[active] + dq, lo, hi)
        return q, it

    def solve(self, targets: np.ndarray, q0: np.ndarray | None = None, tol: float = 1e-10,
              max_iter: int = 50) -> IKResult:
        """Joint values reaching targets (..., legs, 3) (trunk frame, m), started from q0
        (..., nq) or from the stance pose (the leg map's, else the model's reference)."""
        targets = np.asarray(targets, dtype=float)
        if targets.shape[-2:] != (self.nlegs, 3):
            raise ValueError(f"targets must be (..., {self.nlegs}, 3), got {targets.shape}")
        lead = targets.shape[:-2]
        tg = targets.reshape(-1, self.nlegs, 3)
        start = self.q_ref if q0 is None else np.asarray(q0, dtype=float)
        q = np.clip(np.broadcast_to(start, (*lead, self.nq)).reshape(-1, self.nq), self.lo, self.hi)
        worst = 0
        for leg, s in enumerate(self.cols):
            q[:, s], it = self._solve_leg(leg, tg[:, leg], q[:, s].copy(), tol, max_iter)
            worst = max(worst, it)
        err = np.linalg.norm(self.fk(q) - tg, axis=-1)
        return IKResult(q=q.reshape(*lead, self.nq), err=err.reshape(*lead, self.nlegs), iterations=worst)

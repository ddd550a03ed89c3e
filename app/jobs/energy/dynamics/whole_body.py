"""MuJoCo's inverse dynamics of the whole quadruped along a trajectory (Eq. 1-3, 9).

Everything here is MuJoCo's own multibody algebra (``mj_inverse``: M qacc + C qdot - g, the
free joint's force in world axes and its torque in trunk axes about the trunk CoM), never a
point-mass guess. Conventions: body angles theta = (roll, pitch, yaw), R = Rz Ry Rx; the
paper's small-oscillation step (Eq. 5) takes the trunk-frame angular velocity equal to
d(theta)/dt, and the stages that use the NLP's angles keep it; the forward check integrates
MuJoCo's quaternion exactly.
"""

from __future__ import annotations

import mujoco
import numpy as np

from app.robots.quadruped import LEGS, QuadrupedGeometry, build_model, dof_index, leg_ik, qpos_index

GRAVITY = 9.81


def rotation(theta: np.ndarray) -> np.ndarray:
    """(K, 3, 3) from (K, 3) roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = theta[:, 0], theta[:, 1], theta[:, 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    R = np.empty((theta.shape[0], 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    R[:, 1, 0], R[:, 1, 1], R[:, 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    R[:, 2, 0], R[:, 2, 1], R[:, 2, 2] = -sp, cp * sr, cp * cr
    return R


def quat(theta: np.ndarray) -> np.ndarray:
    """(K, 4) MuJoCo quaternions (w, x, y, z) of R = Rz Ry Rx."""
    h = 0.5 * theta
    cr, sr, cp, sp, cy, sy = np.cos(h[:, 0]), np.sin(h[:, 0]), np.cos(h[:, 1]), np.sin(h[:, 1]), np.cos(h[:, 2]), np.sin(h[:, 2])
    return np.stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy], axis=1)


def euler(q: np.ndarray) -> np.ndarray:
    """(K, 3) roll, pitch, yaw of (K, 4) quaternions (inverse of ``quat``)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def periodic_derivatives(f: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives of samples ``f`` (K, ...) of a T-periodic signal on
    K equal steps h (the end point excluded): fourth-order central differences."""
    fp2, fp1, fm1, fm2 = (np.roll(f, s, axis=0) for s in (-2, -1, 1, 2))
    d1 = (-fp2 + 8 * fp1 - 8 * fm1 + fm2) / (12 * h)
    d2 = (-fp2 + 16 * fp1 - 30 * f + 16 * fm1 - fm2) / (12 * h * h)
    return d1, d2


class WholeBody:
    """One compiled model (no floor: contact forces are the stage's unknowns, not MuJoCo's)."""

    def __init__(self, geom: QuadrupedGeometry):
        self.geom = geom
        self.model = build_model(geom, floor=False)
        self.model.opt.gravity[:] = (0.0, 0.0, -GRAVITY)
        self.data = mujoco.MjData(self.model)
        self.qadr = qpos_index(self.model)
        self.vadr = dof_index(self.model)
        self.sites = [self.model.site(f"{l}_tip").id for l in LEGS]
        self.hips = np.array([geom.hip(l) for l in LEGS])
        self.sides = np.array([geom.side(l) for l in LEGS], dtype=float)
        self._jac = np.zeros((3, self.model.nv))

    def leg_angles(self, r: np.ndarray, theta: np.ndarray, feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """IK of all legs for tips at world ``feet`` (K, 4, 3) with the trunk at r, theta (K, 3):
        joint angles (K, 12) and reach mask (K, 4)."""
        R = rotation(theta)
        rel = np.einsum("kji,klj->kli", R, feet - r[:, None, :]) - self.hips[None]
        q, ok = leg_ik(rel, self.geom.links, self.sides[None, :])
        return q.reshape(len(r), 12), ok

    def qpos(self, r: np.ndarray, theta: np.ndarray, q_legs: np.ndarray) -> np.ndarray:
        out = np.zeros((len(r), self.model.nq))
        out[:, :3], out[:, 3:7] = r, quat(theta)
        out[:, self.qadr] = q_legs
        return out

    def qvec(self, v_body: np.ndarray, w_body: np.ndarray, legs: np.ndarray) -> np.ndarray:
        out = np.zeros((len(v_body), self.model.nv))
        out[:, :3], out[:, 3:6] = v_body, w_body
        out[:, self.vadr] = legs
        return out

    def inverse(self, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray, forces: np.ndarray | None = None,
                mass_matrix: bool = False):
        """mj_inverse along a trajectory: qfrc_inverse (K, nv); with ``forces`` (K, 4, 3, world,
        applied at the tips) also their generalised force J^T f (K, nv); with ``mass_matrix``
        the trunk block M_bb (K, 6, 6)."""
        m, d = self.model, self.data
        K = len(qpos)
        qfrc = np.empty((K, m.nv))
        jtf = np.zeros((K, m.nv)) if forces is not None else None
        Mbb = np.empty((K, 6, 6)) if mass_matrix else None
        full = np.zeros((m.nv, m.nv)) if mass_matrix else None
        for k in range(K):
            d.qpos[:], d.qvel[:], d.qacc[:] = qpos[k], qvel[k], qacc[k]
            mujoco.mj_inverse(m, d)
            qfrc[k] = d.qfrc_inverse
            if forces is not None:
                for i, sid in enumerate(self.sites):
                    f = forces[k, i]
                    if f.any():
                        mujoco.mj_jacSite(m, d, self._jac, None, sid)
                        jtf[k] += f @ self._jac
            if mass_matrix:
                mujoco.mj_fullM(m, d, full)
                Mbb[k] = full[:6, :6]
        return qfrc, jtf, Mbb

    def body_wrench_of_forces(self, r: np.ndarray, theta: np.ndarray, feet: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """J_b^T f for tip forces (K, 4, 3): world force sum and trunk-frame torque about the CoM
        (what mj_jacSite gives for the free joint's rows, without a MuJoCo call)."""
        R = rotation(theta)
        torque_w = np.cross(feet - r[:, None, :], forces).sum(axis=1)
        return np.concatenate([forces.sum(axis=1), np.einsum("kji,kj->ki", R, torque_w)], axis=1)

    def joint_torques(self, qfrc: np.ndarray, jtf: np.ndarray) -> np.ndarray:
        """Eq. 3 solved for tau: the leg rows of M qdd + C qd - g - J^T f."""
        return (qfrc - jtf)[:, self.vadr]

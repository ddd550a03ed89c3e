"""Forward check (paper 003, Sec. II-D): integrate the trunk rows of the full multibody
equations (Eq. 2) under given tip forces from the NLP's initial state, the legs following
the world foot paths by IK at every step ("compatible with the body").

Per step: mj_inverse with the trunk's acceleration zero and the legs' accelerations gives
M_bl qdd_l + c_b - g_b (the legs' reaction and the trunk's bias); M_bb qdd_b = J_b^T f - that.
Semi-implicit Euler on MuJoCo's free joint (quaternion integrated by mj_integratePos).
The legs' rates depend on the trunk's path, which is being computed: a first pass uses the
NLP's leg rates, a second pass re-solves the legs by IK along the first pass's trunk and
differentiates their change from the previous pass.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from app.jobs.energy.dynamics.gait import Gait, Task, feet_world
from app.jobs.energy.dynamics.whole_body import WholeBody, euler


@dataclasses.dataclass
class ForwardPath:
    t: np.ndarray  # (K+1,) knots
    r: np.ndarray
    theta: np.ndarray  # roll, pitch, yaw
    v: np.ndarray  # world
    omega: np.ndarray  # trunk frame
    a: np.ndarray
    alpha: np.ndarray
    quat: np.ndarray
    q: np.ndarray  # (K+1, 12) legs
    qd: np.ndarray
    qdd: np.ndarray
    reach_ok: bool


def _interp(t_knots, arr, t):
    """Linear interpolation of knot rows ``arr`` (K+1, n) at times ``t`` (S,)."""
    j = np.clip(np.searchsorted(t_knots, t, side="right") - 1, 0, len(t_knots) - 2)
    w = ((t - t_knots[j]) / (t_knots[j + 1] - t_knots[j]))[:, None]
    return (1 - w) * arr[j] + w * arr[j + 1]


def integrate(wb: WholeBody, gait: Gait, task: Task, t_knots: np.ndarray, r0, quat0, v0, w0, force_at,
              legs_q, legs_qd, legs_qdd, substeps: int = 4, passes: int = 2) -> ForwardPath:
    """``force_at(times) -> (n, 4, 3)`` world tip forces; legs_* (K+1, 12) the first pass's leg motion."""
    m, d = wb.model, wb.data
    K = len(t_knots) - 1
    dt = (t_knots[1] - t_knots[0]) / substeps
    full = np.zeros((m.nv, m.nv))
    trunk = m.body("trunk").id
    path = None
    times = np.arange(K * substeps + 1) * dt
    forces = force_at(times)
    feet_steps = feet_world(gait, task, wb.geom, times)
    steps = K * substeps + 1
    trunk_rows = slice(0, 6)
    for p in range(passes):
        qpos = np.zeros(m.nq)
        qvel = np.zeros(m.nv)
        qpos[:3], qpos[3:7] = r0, quat0
        qvel[:3], qvel[3:6] = v0, w0
        rec = {k: np.zeros((K + 1, n)) for k, n in (("r", 3), ("quat", 4), ("v", 3), ("w", 3), ("a", 3), ("al", 3))}
        lq, lqd, lqdd = (_interp(t_knots, arr, times) for arr in (legs_q, legs_qd, legs_qdd))
        fsum = forces.sum(axis=1)
        for step in range(steps):
            qpos[wb.qadr], qvel[wb.vadr] = lq[step], lqd[step]
            d.qpos[:], d.qvel[:] = qpos, qvel
            d.qacc[:] = 0.0
            d.qacc[wb.vadr] = lqdd[step]
            mujoco.mj_inverse(m, d)
            mujoco.mj_fullM(m, d, full)
            a = feet_steps[step] - qpos[:3]
            f = forces[step]
            torque_w = np.array([(a[:, 1] * f[:, 2] - a[:, 2] * f[:, 1]).sum(), (a[:, 2] * f[:, 0] - a[:, 0] * f[:, 2]).sum(),
                                 (a[:, 0] * f[:, 1] - a[:, 1] * f[:, 0]).sum()])
            jtf = np.concatenate([fsum[step], torque_w @ d.xmat[trunk].reshape(3, 3)])
            acc = np.linalg.solve(full[trunk_rows, trunk_rows], jtf - d.qfrc_inverse[trunk_rows])
            if step % substeps == 0:
                k = step // substeps
                rec["r"][k], rec["quat"][k], rec["v"][k], rec["w"][k] = qpos[:3], qpos[3:7], qvel[:3], qvel[3:6]
                rec["a"][k], rec["al"][k] = acc[:3], acc[3:]
            if step == steps - 1:
                break
            qvel[:6] += dt * acc
            mujoco.mj_integratePos(m, qpos, qvel, dt)
        theta = euler(rec["quat"])
        theta = np.unwrap(theta, axis=0)
        feet = feet_world(gait, task, wb.geom, t_knots)
        q, ok = wb.leg_angles(rec["r"], theta, feet)
        # Differentiate only the (small, smooth) change from this pass's leg motion: the legs'
        # own rates jump at touchdown, which one-sided differences at the ends would smear.
        h = t_knots[1] - t_knots[0]
        dq = q - legs_q
        dqd = np.gradient(dq, h, axis=0, edge_order=2)
        qd = legs_qd + dqd
        qdd = legs_qdd + np.gradient(dqd, h, axis=0, edge_order=2)
        path = ForwardPath(t=t_knots, r=rec["r"], theta=theta, v=rec["v"], omega=rec["w"], a=rec["a"],
                           alpha=rec["al"], quat=rec["quat"], q=q, qd=qd, qdd=qdd, reach_ok=bool(ok.all()))
        legs_q, legs_qd, legs_qdd = q, qd, qdd
    return path

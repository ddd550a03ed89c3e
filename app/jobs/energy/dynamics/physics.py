"""The optimised gait in full MuJoCo physics (beyond paper 003, which stops at the
multibody equations with prescribed contact forces).

The robot stands on a flat floor with MuJoCo's soft contacts (elliptic cone, the task's
friction) and is driven by joint torques only:
  tau = tau_ff(t)                          the solution's joint torques (Eq. 3, final stage)
      + Kp (q_ref - q) + Kd (qd_ref - qd)  joint PD on the solution's leg angles
      - J_l^T df                           stance legs only: balance feedback
Open-loop tracking does not hold every trot: a trot stands on a line of two feet (no
support polygon), and a roll or a speed error about that line grows for the whole stance
(an inverted pendulum, time constant sqrt(h/g) = 0.23 s). We measured that joint PD with
the feed-forward alone holds the paper's trot (T = 0.46 s) for 40 periods, but the slow
trot a GA found at T = 0.8 s fell within 3 periods. The smallest feedback we found that
holds both is Raibert's foot placement: every swing foot's planned target is shifted by
k (v - v_ref), the horizontal trunk-velocity error, blended in over the swing, with k a
fraction of the stance time (0.5 x beta T: 0.115 s for the paper's trot, 0.2 s at
T = 0.8 s; 0.3 s made the fast trot drift 0.11 rad per period). It changes only where the
feet land, not the stance torques. Optional (``balance``): a trunk damping wrench on the
velocity and angular-rate errors, dW = [Kd_v e_v ; Kd_w e_omega], spread over the feet in
contact by least-norm forces (df = A^+ dW, A = [I ...; [p_i - r]x ...]); position and
attitude terms exist (kp_pos, kp_att) but are off: with them the T = 0.73 s trot fell
after 4 s. The feedback's share of the work is reported.

The reference repeats every period with x advanced by the distance the solution covers.
Reports: whether it stays up (trunk above half its height, roll and pitch below 0.5 rad),
realised speed and mean height, CoT in physics (Eq. 11's first term on the measured
torques and joint rates) and the part of it the feedback adds, and the drift from
periodicity: the trunk state at each period boundary against the one before.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from app.jobs.energy.dynamics.whole_body import GRAVITY, euler, quat
from app.robots.quadruped import LEGS, QuadrupedGeometry, build_model, dof_index, leg_fk, leg_ik, qpos_index


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    periods: int = 10
    timestep: float = 0.001
    kp_joint: float = 300.0  # N m / rad
    kd_joint: float = 8.0  # N m s / rad
    kp_pos: float = 0.0  # N / m (off: see the module's docstring)
    kd_pos: float = 200.0  # N s / m
    kp_att: float = 0.0  # N m / rad (off)
    kd_att: float = 20.0  # N m s / rad
    balance: bool = False
    foot_placement_s: float = 0.0  # Raibert gain: swing feet land k (v - v_ref) further (0 = off)
    friction: float | None = None  # None: the task's
    mass_scale: float = 1.0  # every body's mass and inertia (perturbation)
    record_every: int = 10  # steps between recorded frames


@dataclasses.dataclass
class Reference:
    """One period of the solution on its K+1 knots (t from 0 to T)."""

    period: float
    t: np.ndarray
    r: np.ndarray
    theta: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    q: np.ndarray  # (K+1, 12)
    qd: np.ndarray
    tau: np.ndarray  # (K+1, 12)
    stance: np.ndarray  # (K+1, 4) bool
    distance: float
    touchdown: tuple = (0.0, 0.0, 0.0, 0.0)
    duty: tuple = (1.0, 1.0, 1.0, 1.0)

    def at(self, t: float) -> dict[str, np.ndarray]:
        n, tau_ = divmod(t, self.period)
        j = min(int(tau_ / (self.t[1] - self.t[0])), len(self.t) - 2)
        w = (tau_ - self.t[j]) / (self.t[j + 1] - self.t[j])
        out = {k: (1 - w) * getattr(self, k)[j] + w * getattr(self, k)[j + 1]
               for k in ("r", "theta", "v", "omega", "q", "qd", "tau")}
        out["r"] = out["r"] + np.array([n * self.distance, 0.0, 0.0])
        out["stance"] = self.stance[j]
        return out


def _model(geom: QuadrupedGeometry, cfg: PhysicsConfig, friction: float) -> mujoco.MjModel:
    g = dataclasses.replace(geom, friction=friction, timestep=cfg.timestep)
    m = build_model(g, floor=True)
    if cfg.mass_scale != 1.0:
        m.body_mass[1:] *= cfg.mass_scale
        m.body_inertia[1:] *= cfg.mass_scale
    return m


@dataclasses.dataclass
class _Sim:
    """A play-back under way: the model, its data and the indices the controller uses."""

    geom: QuadrupedGeometry
    ref: Reference
    cfg: PhysicsConfig
    m: mujoco.MjModel
    d: mujoco.MjData
    qadr: np.ndarray
    vadr: np.ndarray
    trunk: int
    sites: list[int]
    jac: np.ndarray


def _start(geom: QuadrupedGeometry, ref: Reference, friction: float, cfg: PhysicsConfig) -> _Sim:
    """The robot placed on the reference's first knot, moving as it does there."""
    m = _model(geom, cfg, cfg.friction if cfg.friction is not None else friction)
    d = mujoco.MjData(m)
    sim = _Sim(geom, ref, cfg, m, d, qpos_index(m), dof_index(m), m.body("trunk").id,
               [m.site(f"{l}_tip").id for l in LEGS], np.zeros((3, m.nv)))
    s0 = ref.at(0.0)
    d.qpos[:3], d.qpos[3:7] = s0["r"], quat(s0["theta"][None])[0]
    d.qpos[sim.qadr] = s0["q"]
    d.qvel[:3], d.qvel[3:6] = s0["v"], s0["omega"]
    d.qvel[sim.vadr] = s0["qd"]
    mujoco.mj_forward(m, d)
    return sim


def simulate(geom: QuadrupedGeometry, ref: Reference, friction: float, cfg: PhysicsConfig = PhysicsConfig()) -> dict[str, Any]:
    sim = _start(geom, ref, friction, cfg)
    m, d, vadr = sim.m, sim.d, sim.vadr
    steps = int(round(cfg.periods * ref.period / cfg.timestep))
    work = work_ff = 0.0
    fell_at = None
    frames_t, frames_q = [], []
    boundary = []
    per_period = int(round(ref.period / cfg.timestep))
    for step in range(steps + 1):
        t = step * cfg.timestep
        if step % per_period == 0:
            boundary.append(np.concatenate([d.qpos[:3], euler(d.qpos[3:7][None])[0], d.qvel[:6]]))
        if step % cfg.record_every == 0:
            frames_t.append(t)
            frames_q.append(d.qpos.copy())
        if step == steps:
            break
        tau, tau_ff = _torques(sim, t)
        d.ctrl[:] = tau
        mujoco.mj_step(m, d)
        applied = d.actuator_force.copy()
        work += abs(applied @ d.qvel[vadr]) * cfg.timestep
        work_ff += abs(tau_ff @ d.qvel[vadr]) * cfg.timestep
        if _fallen(d, ref):
            fell_at = t
            break
    return _report(sim, fell_at, step, work, work_ff, np.asarray(frames_t), np.asarray(frames_q),
                   np.asarray(boundary))


def _torques(sim: _Sim, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(the joint torques to apply at ``t``, their feed-forward part): the solution's
    torques, joint PD on its leg angles (swing targets moved by foot placement) and the
    balance feedback, each as the module's docstring says."""
    cfg, d = sim.cfg, sim.d
    ref_t = sim.ref.at(t)
    q, qd = d.qpos[sim.qadr], d.qvel[sim.vadr]
    tau_ff = ref_t["tau"]
    q_target = ref_t["q"]
    if cfg.foot_placement_s > 0.0:
        q_target = _place_swing_feet(sim.geom, sim.ref, t, ref_t, d, sim.trunk, cfg.foot_placement_s)
    tau = tau_ff + cfg.kp_joint * (q_target - q) + cfg.kd_joint * (ref_t["qd"] - qd)
    if cfg.balance:
        _balance(sim, ref_t, tau)
    return tau, tau_ff


def _balance(sim: _Sim, ref_t: dict[str, np.ndarray], tau: np.ndarray) -> None:
    """Adds to ``tau`` the stance legs' share of the trunk damping wrench: least-norm foot
    forces df = A^+ dW, applied through each foot's Jacobian."""
    cfg, m, d, trunk = sim.cfg, sim.m, sim.d, sim.trunk
    R = d.xmat[trunk].reshape(3, 3)
    th = euler(d.qpos[3:7][None])[0]
    e_th = ref_t["theta"] - th
    e_th[2] = (e_th[2] + np.pi) % (2 * np.pi) - np.pi
    w_world = R @ d.qvel[3:6]
    dW = np.concatenate([cfg.kp_pos * (ref_t["r"] - d.qpos[:3]) + cfg.kd_pos * (ref_t["v"] - d.qvel[:3]),
                         cfg.kp_att * e_th + cfg.kd_att * (R @ ref_t["omega"] - w_world)])
    legs = np.flatnonzero(ref_t["stance"])
    if not legs.size:
        return
    A = np.zeros((6, 3 * legs.size))
    for j, i in enumerate(legs):
        a = d.site_xpos[sim.sites[i]] - d.xipos[trunk]
        A[:3, 3 * j:3 * j + 3] = np.eye(3)
        A[3:, 3 * j:3 * j + 3] = [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]
    df = np.linalg.lstsq(A, dW, rcond=None)[0]
    for j, i in enumerate(legs):
        mujoco.mj_jacSite(m, d, sim.jac, None, sim.sites[i])
        cols = sim.vadr[3 * i:3 * i + 3]
        tau[3 * i:3 * i + 3] -= sim.jac[:, cols].T @ df[3 * j:3 * j + 3]


def _fallen(d: mujoco.MjData, ref: Reference) -> bool:
    """The trunk below half the reference's mean height, rolled or pitched past 0.5 rad, or
    no longer finite."""
    z = d.qpos[2]
    rp = euler(d.qpos[3:7][None])[0][:2]
    return bool(z < 0.5 * ref.r[:, 2].mean() or np.abs(rp).max() > 0.5 or not np.isfinite(z))


def _drift(boundary: np.ndarray) -> dict[str, float]:
    """Mean change of the trunk state from one period boundary to the next."""
    if len(boundary) < 2:
        return {}
    diff = np.abs(np.diff(boundary, axis=0))
    return {"pos_m": float(diff[:, 1:3].max(axis=1).mean()), "angle_rad": float(diff[:, 3:6].max(axis=1).mean()),
            "vel_m_s": float(diff[:, 6:9].max(axis=1).mean()), "rate_rad_s": float(diff[:, 9:12].max(axis=1).mean())}


def _report(sim: _Sim, fell_at: float | None, step: int, work: float, work_ff: float, frames_t: np.ndarray,
            frames: np.ndarray, boundary: np.ndarray) -> dict[str, Any]:
    cfg, ref = sim.cfg, sim.ref
    duration = step * cfg.timestep if fell_at is None else fell_at
    distance = float(sim.d.qpos[0] - ref.r[0, 0])
    mass = float(sim.m.body_subtreemass[sim.trunk])
    mgd = mass * GRAVITY * max(abs(distance), 1e-9)
    return {
        "stays_up": fell_at is None,
        "fell_at_s": fell_at,
        "periods_completed": cfg.periods if fell_at is None else int(fell_at / ref.period),
        "speed_m_s": distance / duration if duration > 0 else 0.0,
        "mean_height_m": float(frames[:, 2].mean()),
        "cot": work / mgd,
        "cot_feedforward_part": work_ff / mgd,
        "drift_per_period": _drift(boundary),
        "duration_s": duration,
        "frames_t": frames_t,
        "frames_qpos": frames,
        "steps": step,
        "model": sim.m,
    }


def _place_swing_feet(geom, ref: Reference, t: float, ref_t: dict, d, trunk: int, gain: float) -> np.ndarray:
    """Raibert's foot placement: each swing foot's planned target (body frame) shifted by
    gain x (measured - planned) horizontal trunk velocity, blended in over the swing."""
    q = ref_t["q"].copy()
    R = d.xmat[trunk].reshape(3, 3)
    dv = d.qvel[:3] - ref_t["v"]
    dv[2] = 0.0
    shift = R.T @ (gain * dv)
    shift[2] = 0.0
    T = ref.period
    for i, leg in enumerate(LEGS):
        beta = ref.duty[i]
        tau = (t - ref.touchdown[i]) % T
        if beta >= 1.0 or tau < beta * T:
            continue
        u = (tau - beta * T) / ((1.0 - beta) * T)
        s = u * u * (3.0 - 2.0 * u)
        hip, side = geom.hip(leg), geom.side(leg)
        p = leg_fk(q[3 * i:3 * i + 3], geom.links, side) + s * shift
        qi, ok = leg_ik(p, geom.links, side)
        if ok:
            q[3 * i:3 * i + 3] = qi
    return q


def reference_from(trajectories: dict[str, Any], gait, speed: float) -> Reference:
    """The periodic NLP trunk and leg path with the QP stage's joint torques (Eq. 3 along
    that path with the residual-free forces) as the feed-forward."""
    sol, legs = trajectories["nlp"], trajectories["legs_nlp"]
    tk = trajectories["t_knots"]
    K = len(tk) - 1

    def close(a):
        return np.vstack([a, a[:1]])

    # Torques live on the odd knots: periodic linear interpolation onto every knot.
    ts, tau_s = trajectories["t_samples"], trajectories["tau_qp"]
    T = gait.period
    ts_ext = np.concatenate([ts[-1:] - T, ts, ts[:1] + T])
    tau_ext = np.vstack([tau_s[-1:], tau_s, tau_s[:1]])
    tau = np.stack([np.interp(tk, ts_ext, tau_ext[:, j]) for j in range(12)], axis=1)
    _, stance = gait.phase(tk)
    return Reference(period=T, t=tk, r=sol.r, theta=sol.theta, v=sol.v, omega=sol.omega, q=close(legs.q),
                     qd=close(legs.qd), tau=tau, stance=stance, touchdown=tuple(gait.touchdown), duty=tuple(gait.duty),
                     distance=speed * T)

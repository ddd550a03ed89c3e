"""One fitness evaluation of paper 003 (Sec. II): dummy legs -> NLP -> residual -> QP ->
forward check -> torques, CoT and Eq. 11.

Time grid: K knots per period for the NLP (forces, trunk path); residuals, the QP, torques
and CoT use the K/2 odd knots ("samples"), so no sample falls on a trot's switching
instant, where no leg may push. Eq. 11 as printed, with its two terms reported apart:
J = CoT + jerk_weight * (1/T) int sum_i |dF_i/dt| dt, CoT = int |tau . qdot_l| dt / (m g d),
m the whole robot's mass, d the distance covered in the period. (The papers README: the
two terms have different units; the weight is the spec's.)

Feasibility, in the order checked (the first failure names the candidate's penalty):
"ik_reach" (a dummy or NLP leg cannot reach its foot path), "nlp" (the NLP finds no
solution satisfying its constraints), "periodicity" (the forward check's periodicity
error w exceeds 1, see ``periodicity_error``). Penalties are above every feasible J and
ordered (reach > NLP > periodicity), growing with how badly the constraint fails, so the
GA is pulled towards the feasible set.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from app.jobs.energy.dynamics.dummy_legs import dummy_leg_wrench, leg_motion, nominal_body
from app.jobs.energy.dynamics.forward import ForwardPath, integrate
from app.jobs.energy.dynamics.gait import Gait, Task, feet_world
from app.jobs.energy.dynamics.nlp import SRBNLP, SRBProblem
from app.jobs.energy.dynamics.qp import residual_qp
from app.jobs.energy.dynamics.whole_body import GRAVITY, WholeBody, quat, rotation
from app.robots.quadruped import QuadrupedGeometry

# Periodicity tolerances: w = max over components of |end - start| / tolerance (w <= 1 passes).
PERIODICITY_TOL = {"pos_m": 0.01, "angle_rad": 0.02, "vel_m_s": 0.05, "rate_rad_s": 0.2, "speed_m_s": 0.05}
PENALTY = {"ik_reach": 1e6, "nlp": 1e5, "periodicity": 1e4}
AXES = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclasses.dataclass(frozen=True)
class EvalConfig:
    knots: int = 192  # per period (even); 96 and 384 move the final CoT by +1.7 % and -0.5 % (docs/energy.md)
    k: int = 4  # spline coefficients per contact phase and axis
    substeps: int = 4  # forward-check steps per knot
    leg_dynamics: bool = True  # False: SRB with massless legs (the robot's whole mass in the trunk)
    jerk_weight: float = 1e-4  # s: Eq. 11's second term weight (as printed: 1)
    polish: bool = False  # run SLSQP on the bilinear NLP after the linearised sweeps
    residual_iterations: int = 2  # NLP re-solves with the legs' true wrench (0 = the paper's single pass)
    forward_passes: int = 1


def periodicity_error(path: ForwardPath, speed: float, period: float) -> tuple[float, dict[str, float]]:
    d = {
        "pos_m": float(np.abs(path.r[-1, 1:] - path.r[0, 1:]).max()),
        "angle_rad": float(np.abs(path.theta[-1] - path.theta[0]).max()),
        "vel_m_s": float(np.abs(path.v[-1] - path.v[0]).max()),
        "rate_rad_s": float(np.abs(path.omega[-1] - path.omega[0]).max()),
        "speed_m_s": float(abs((path.r[-1, 0] - path.r[0, 0]) / period - speed)),
    }
    return max(d[k] / PERIODICITY_TOL[k] for k in d), d


def _stance_edges(stance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    first = stance & ~np.roll(stance, 1, axis=0)
    last = stance & ~np.roll(stance, -1, axis=0)
    return first, last


def _cot(tau: np.ndarray, qd: np.ndarray, dt: float, mass: float, distance: float) -> dict[str, float]:
    power = np.einsum("kj,kj->k", tau, qd)
    work_abs = float(np.abs(power).sum() * dt)
    work_joint = float(np.abs(tau * qd).sum() * dt)
    mgd = mass * GRAVITY * max(distance, 1e-9)
    return {"cot": work_abs / mgd, "cot_per_joint_abs": work_joint / mgd, "work_J": work_abs,
            "peak_torque_Nm": float(np.abs(tau).max())}


def _eps(e: np.ndarray) -> dict[str, float]:
    """RMS per axis (N for x, y, z; N m for roll, pitch, yaw) and the overall RMS."""
    rms = np.sqrt((e**2).mean(axis=0))
    out = {a: float(v) for a, v in zip(AXES, rms)}
    out["norm"] = float(np.sqrt((e**2).sum(axis=1).mean()))
    return out


def _jerk_term(forces: np.ndarray, dt: float, period: float) -> float:
    """(1/T) int sum_i |dF_i/dt| dt over one period of samples (periodic differences)."""
    rate = (np.roll(forces, -1, axis=0) - forces) / dt
    return float(np.linalg.norm(rate, axis=2).sum() * dt / period)


def _penalty(kind: str, amount: float) -> float:
    return PENALTY[kind] * (1.0 + min(max(amount, 0.0), 1e3))


def evaluate(geom: QuadrupedGeometry, gait: Gait, task: Task, cfg: EvalConfig = EvalConfig(),
             detail: bool = False) -> dict[str, Any]:
    """Fitness J and its parts for one candidate; ``detail`` adds every stage's trajectories."""
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    out: dict[str, Any] = {"feasible": False, "failed": None}

    def lap(name, t0):
        timings[name] = time.perf_counter() - t0
        return time.perf_counter()

    t0 = time.perf_counter()
    wb = WholeBody(geom)
    K, T = cfg.knots, gait.period
    t0 = lap("model", t0)
    legs0, fl, ml = dummy_leg_wrench(wb, gait, task, K)
    if not legs0.reach_ok.all():
        out.update(failed="ik_reach", fitness=_penalty("ik_reach", float((~legs0.reach_ok).mean())))
        out["seconds"] = time.perf_counter() - t_start
        return out
    t0 = lap("dummy_legs", t0)
    tk = np.arange(K + 1) * T / K
    feet = feet_world(gait, task, geom, tk)
    if cfg.leg_dynamics:
        mass, fl1, ml1 = geom.trunk_mass, np.vstack([fl, fl[:1]]), np.vstack([ml, ml[:1]])
    else:
        mass, fl1, ml1 = geom.total_mass, np.zeros((K + 1, 3)), np.zeros((K + 1, 3))
    r_nom, _ = nominal_body(task, tk)
    n_iter = cfg.residual_iterations if cfg.leg_dynamics else 0
    smp = np.arange(1, K, 2)
    ts, dts = tk[smp], 2 * T / K
    eps_first = None
    nlp_seconds = 0.0
    for it in range(n_iter + 1):
        prob = SRBProblem(gait=gait, mass=mass, inertia=np.asarray(geom.trunk_inertia), speed=task.speed,
                          height=task.height, friction=task.friction, feet=feet, f_legs=fl1, m_legs=ml1, k=cfg.k,
                          weight=geom.total_mass * GRAVITY)
        sol = SRBNLP(prob).solve(r_nom, polish=cfg.polish)
        nlp_seconds += sol.seconds
        if not sol.success:
            out.update(failed="nlp", fitness=_penalty("nlp", sol.constraint_violation),
                       nlp={"success": False, "message": sol.message, "iteration": it})
            out["seconds"] = time.perf_counter() - t_start
            return out
        # Residual of the NLP solution in the full equations (Eq. 9), on every knot.
        legs1 = leg_motion(wb, gait, task, tk[:K], sol.r[:K], sol.theta[:K])
        if not legs1.reach_ok.all():
            out.update(failed="ik_reach", fitness=_penalty("ik_reach", float((~legs1.reach_ok).mean())))
            out["seconds"] = time.perf_counter() - t_start
            return out
        qpos_k = wb.qpos(sol.r[:K], sol.theta[:K], legs1.q)
        qvel_k = wb.qvec(sol.v[:K], sol.omega[:K], legs1.qd)
        qacc_k = wb.qvec(sol.a[:K], sol.alpha[:K], legs1.qdd)
        qfrc_k, _, _ = wb.inverse(qpos_k, qvel_k, qacc_k)
        eps_k = qfrc_k[:, :6] - wb.body_wrench_of_forces(sol.r[:K], sol.theta[:K], feet[:K], sol.forces[:K])
        if it == 0:
            eps_first = eps_k[smp]
            sol_first, legs_first = sol, legs1
            # The paper's CoT_NLP: Eq. 3's torques along the first NLP's path with its forces.
            qf, jf, _ = wb.inverse(qpos_k[smp], qvel_k[smp], qacc_k[smp], forces=sol.forces[smp])
            tau_first = wb.joint_torques(qf, jf)
        # The legs' true pull on the trunk along this path replaces the dummy legs' (beyond the
        # paper: two point feet cannot make a moment about the line through them, so what the
        # SRB model gets wrong about that axis no force redistribution can remove).
        Rk = rotation(sol.theta[:K])
        fl_it = fl1[:K] - eps_k[:, :3]
        ml_it = ml1[:K] - np.einsum("kij,kj->ki", Rk, eps_k[:, 3:])
        fl1, ml1 = np.vstack([fl_it, fl_it[:1]]), np.vstack([ml_it, ml_it[:1]])
    t0 = lap("nlp", t0)
    out["nlp"] = {"success": sol.success, "message": sol.message, "iterations": sol.iterations,
                  "residual_iterations": n_iter, "constraint_violation": sol.constraint_violation,
                  "seconds": nlp_seconds, "jerk_N2_s": sol.jerk}
    qpos, qvel, qacc = qpos_k[smp], qvel_k[smp], qacc_k[smp]
    f_nlp = sol.forces[smp]
    qfrc, jtf_nlp, _ = wb.inverse(qpos, qvel, qacc, forces=f_nlp)
    eps_nlp = qfrc[:, :6] - jtf_nlp[:, :6]
    tau_nlp = wb.joint_torques(qfrc, jtf_nlp)
    t0 = lap("residual", t0)
    # --- QP (Eq. 10) -------------------------------------------------------------------
    _, stance = gait.phase(ts)
    first, last = _stance_edges(stance)
    R = rotation(sol.theta[smp])
    arms = feet[smp] - sol.r[smp][:, None, :]
    f_qp, qp_status = residual_qp(qfrc[:, :6], arms, R, stance, first, last, f_nlp, task.friction,
                                  geom.total_mass * GRAVITY)
    _, jtf_qp, _ = wb.inverse(qpos, qvel, qacc, forces=f_qp)
    eps_qp = qfrc[:, :6] - jtf_qp[:, :6]
    tau_qp = wb.joint_torques(qfrc, jtf_qp)
    t0 = lap("qp", t0)
    # --- forward check with the QP forces, linear between samples and zero at every leg's
    # touchdown and lift-off instant (the force ramps up from contact, as in Fig. 2).
    qp_force = _sampled_force(gait, ts, f_qp)
    legs_k = (np.vstack([legs1.q, legs1.q[:1]]), np.vstack([legs1.qd, legs1.qd[:1]]),
              np.vstack([legs1.qdd, legs1.qdd[:1]]))
    th0 = sol.theta[0]
    fwd = integrate(wb, gait, task, tk, sol.r[0], quat(th0[None])[0], sol.v[0], sol.omega[0], qp_force, *legs_k,
                    substeps=cfg.substeps, passes=cfg.forward_passes)
    t0 = lap("forward", t0)
    w, w_parts = periodicity_error(fwd, task.speed, T)
    qpos_f = wb.qpos(fwd.r[smp], fwd.theta[smp], fwd.q[smp])
    qpos_f[:, 3:7] = fwd.quat[smp]
    qvel_f = wb.qvec(fwd.v[smp], fwd.omega[smp], fwd.qd[smp])
    qacc_f = wb.qvec(fwd.a[smp], fwd.alpha[smp], fwd.qdd[smp])
    qfrc_f, jtf_f, _ = wb.inverse(qpos_f, qvel_f, qacc_f, forces=f_qp)
    eps_final = qfrc_f[:, :6] - jtf_f[:, :6]
    tau_f = wb.joint_torques(qfrc_f, jtf_f)
    t0 = lap("torques", t0)
    mt = geom.total_mass
    d_nlp = task.speed * T
    d_fwd = float(fwd.r[-1, 0] - fwd.r[0, 0])
    cot = {
        "nlp_first": _cot(tau_first, legs_first.qd[smp], dts, mt, d_nlp),
        "nlp": _cot(tau_nlp, legs1.qd[smp], dts, mt, d_nlp),
        "qp": _cot(tau_qp, legs1.qd[smp], dts, mt, d_nlp),
        "final": _cot(tau_f, fwd.qd[smp], dts, mt, d_fwd),
    }
    jerk = _jerk_term(f_qp, dts, T)
    feasible = w <= 1.0 and fwd.reach_ok
    fitness = cot["final"]["cot"] + cfg.jerk_weight * jerk
    out.update(
        feasible=bool(feasible),
        failed=None if feasible else ("ik_reach" if not fwd.reach_ok else "periodicity"),
        fitness=float(fitness) if feasible else _penalty("periodicity", w),
        cot={k: v["cot"] for k, v in cot.items()},
        cot_detail=cot,
        jerk_term_N_s=jerk,
        objective_terms={"cot": cot["final"]["cot"], "jerk": cfg.jerk_weight * jerk},
        eps={"nlp": _eps(eps_first), "nlp_iterated": _eps(eps_nlp), "qp": _eps(eps_qp), "final": _eps(eps_final)},
        periodicity_error=w,
        periodicity=w_parts,
        qp_failures=int(qp_status.sum()),
        distance_m=d_fwd,
    )
    if not fwd.reach_ok and feasible is False and out["failed"] == "ik_reach":
        out["fitness"] = _penalty("ik_reach", 0.0)
    timings["total"] = time.perf_counter() - t_start
    out["timings_s"] = timings
    out["seconds"] = timings["total"]
    if detail:
        legs_f = tuple(np.vstack([a, a[:1]]) for a in (legs_first.q, legs_first.qd, legs_first.qdd))
        s1 = sol_first
        fwd_nlp = integrate(wb, gait, task, tk, s1.r[0], quat(s1.theta[:1])[0], s1.v[0], s1.omega[0],
                            lambda times: _interp_forces(tk, s1.forces, times), *legs_f,
                            substeps=cfg.substeps, passes=cfg.forward_passes)
        w_nlp, _ = periodicity_error(fwd_nlp, task.speed, T)
        out["nlp_forward_periodicity_error"] = w_nlp
        out["trajectories"] = {
            "t_knots": tk, "t_samples": ts, "nlp": sol, "forward_nlp": fwd_nlp, "final": fwd,
            "f_nlp": f_nlp, "f_qp": f_qp, "eps_nlp": eps_nlp, "eps_qp": eps_qp, "eps_final": eps_final,
            "tau_nlp": tau_nlp, "tau_qp": tau_qp, "tau_final": tau_f, "legs_nlp": legs1, "stance": stance,
            "dummy_f_legs": fl, "dummy_m_legs": ml, "wrench_nlp": jtf_nlp[:, :6], "wrench_qp": jtf_qp[:, :6],
            # The paper's NLP (first pass, dummy legs only): Fig. 3's and Fig. 4's black curves.
            "nlp_first": s1, "f_nlp_first": s1.forces[smp], "eps_nlp_first": eps_first,
            "wrench_nlp_first": wb.body_wrench_of_forces(s1.r[smp], s1.theta[smp], feet[smp], s1.forces[smp]),
        }
    return out


def _sampled_force(gait: Gait, ts: np.ndarray, f: np.ndarray):
    T = gait.period
    series = []
    for i in range(4):
        ti, beta = gait.touchdown[i], gait.duty[i]
        t_pts = list(ts)
        f_pts = list(f[:, i])
        if beta < 1.0:
            for edge in (ti % T, (ti + beta * T) % T):
                t_pts.append(edge)
                f_pts.append(np.zeros(3))
        order = np.argsort(t_pts, kind="stable")
        tp, fp = np.asarray(t_pts)[order], np.asarray(f_pts)[order]
        # Periodic extension by one point on each side.
        tp = np.concatenate([tp[-1:] - T, tp, tp[:1] + T])
        fp = np.concatenate([fp[-1:], fp, fp[:1]])
        series.append((tp, fp))

    def at(times):
        tau = np.mod(times, T)
        out = np.zeros((len(times), 4, 3))
        for i, (tp, fp) in enumerate(series):
            for ax in range(3):
                out[:, i, ax] = np.interp(tau, tp, fp[:, ax])
        return out

    return at


def _interp_forces(tk: np.ndarray, F: np.ndarray, times: np.ndarray) -> np.ndarray:
    j = np.clip(np.searchsorted(tk, times, side="right") - 1, 0, len(tk) - 2)
    w = ((times - tk[j]) / (tk[j + 1] - tk[j]))[:, None, None]
    return (1 - w) * F[j] + w * F[j + 1]

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


class _Infeasible(Exception):
    """A stage found the candidate infeasible: the evaluation ends with its penalty."""

    def __init__(self, kind: str, amount: float, **extra: Any):
        super().__init__(kind)
        self.kind, self.amount, self.extra = kind, amount, extra


def _check_reach(legs) -> None:
    if not legs.reach_ok.all():
        raise _Infeasible("ik_reach", float((~legs.reach_ok).mean()))


class _Laps:
    """Wall time per stage (reported under the summary's timing, never in a result)."""

    def __init__(self):
        self.start = self.t0 = time.perf_counter()
        self.timings: dict[str, float] = {}

    def lap(self, name: str) -> None:
        self.timings[name] = time.perf_counter() - self.t0
        self.t0 = time.perf_counter()

    def total(self) -> float:
        return time.perf_counter() - self.start


@dataclasses.dataclass
class _Grid:
    """One candidate's model on its time grid: K + 1 knots over the period for the NLP,
    the K/2 odd ones (``smp``, at times ``ts``, ``dts`` apart) for everything after it."""

    wb: WholeBody
    geom: QuadrupedGeometry
    gait: Gait
    task: Task
    cfg: EvalConfig
    tk: np.ndarray
    smp: np.ndarray
    feet: np.ndarray  # world foot paths on the knots

    @property
    def K(self) -> int:
        return self.cfg.knots

    @property
    def T(self) -> float:
        return self.gait.period

    @property
    def ts(self) -> np.ndarray:
        return self.tk[self.smp]

    @property
    def dts(self) -> float:
        return 2 * self.T / self.K


@dataclasses.dataclass
class _NLPStage:
    """The last NLP pass (its path, legs and whole-body state on the knots) and the first,
    the paper's own, which Fig. 3 and 4 and CoT_NLP are about."""

    sol: Any
    legs: Any
    qpos_k: np.ndarray
    qvel_k: np.ndarray
    qacc_k: np.ndarray
    first: Any
    legs_first: Any
    eps_first: np.ndarray
    tau_first: np.ndarray
    passes: int  # residual iterations run after the first
    seconds: float


@dataclasses.dataclass
class _Forces:
    """One set of contact forces on the samples: the trunk wrench they make, what is left of
    the full equations (eps) and the joint torques they need."""

    f: np.ndarray
    wrench: np.ndarray  # J^T f on every DoF
    eps: np.ndarray
    tau: np.ndarray


def evaluate(geom: QuadrupedGeometry, gait: Gait, task: Task, cfg: EvalConfig = EvalConfig(),
             detail: bool = False) -> dict[str, Any]:
    """Fitness J and its parts for one candidate; ``detail`` adds every stage's trajectories."""
    laps = _Laps()
    out: dict[str, Any] = {"feasible": False, "failed": None}
    try:
        wb = WholeBody(geom)
        laps.lap("model")
        legs0, fl, ml = dummy_leg_wrench(wb, gait, task, cfg.knots)
        _check_reach(legs0)
        laps.lap("dummy_legs")
        g = _grid(wb, geom, gait, task, cfg)
        nlp = _nlp(g, fl, ml)
    except _Infeasible as bad:
        out.update(failed=bad.kind, fitness=_penalty(bad.kind, bad.amount), **bad.extra)
        out["seconds"] = laps.total()
        return out
    laps.lap("nlp")
    sol = nlp.sol
    out["nlp"] = {"success": sol.success, "message": sol.message, "iterations": sol.iterations,
                  "residual_iterations": nlp.passes, "constraint_violation": sol.constraint_violation,
                  "seconds": nlp.seconds, "jerk_N2_s": sol.jerk}
    qpos, qvel, qacc = nlp.qpos_k[g.smp], nlp.qvel_k[g.smp], nlp.qacc_k[g.smp]
    f_nlp = sol.forces[g.smp]
    qfrc, jtf_nlp, _ = wb.inverse(qpos, qvel, qacc, forces=f_nlp)
    at_nlp = _forces(g, qfrc, jtf_nlp, f_nlp)
    laps.lap("residual")
    f_qp, stance, qp_status = _qp(g, sol, qfrc, f_nlp)
    _, jtf_qp, _ = wb.inverse(qpos, qvel, qacc, forces=f_qp)
    at_qp = _forces(g, qfrc, jtf_qp, f_qp)
    laps.lap("qp")
    # The forward check with the QP forces, linear between samples and zero at every leg's
    # touchdown and lift-off instant (the force ramps up from contact, as in Fig. 2).
    fwd = _integrate(g, sol, nlp.legs, _sampled_force(gait, g.ts, f_qp))
    laps.lap("forward")
    w, w_parts = periodicity_error(fwd, task.speed, g.T)
    final = _final_forces(g, fwd, f_qp)
    laps.lap("torques")
    out.update(_score(g, nlp, at_nlp, at_qp, final, fwd, w, w_parts, qp_status))
    out["timings_s"] = laps.timings | {"total": laps.total()}
    out["seconds"] = out["timings_s"]["total"]
    if detail:
        out |= _detail(g, nlp, at_nlp, at_qp, final, fwd, stance, fl, ml)
    return out


def _grid(wb: WholeBody, geom: QuadrupedGeometry, gait: Gait, task: Task, cfg: EvalConfig) -> _Grid:
    K = cfg.knots
    tk = np.arange(K + 1) * gait.period / K
    return _Grid(wb=wb, geom=geom, gait=gait, task=task, cfg=cfg, tk=tk, smp=np.arange(1, K, 2),
                 feet=feet_world(gait, task, geom, tk))


def _close(a: np.ndarray) -> np.ndarray:
    """A periodic series on K knots closed by its first row (K + 1 rows)."""
    return np.vstack([a, a[:1]])


def _nlp(g: _Grid, fl: np.ndarray, ml: np.ndarray) -> _NLPStage:
    """The NLP, then ``residual_iterations`` re-solves with the legs' true pull on the trunk
    along the last path in place of the dummy legs' (beyond the paper: two point feet
    cannot make a moment about the line through them, so what the SRB model gets wrong
    about that axis no force redistribution can remove)."""
    K, cfg, geom = g.K, g.cfg, g.geom
    if cfg.leg_dynamics:
        mass, fl1, ml1 = geom.trunk_mass, _close(fl), _close(ml)
    else:
        mass, fl1, ml1 = geom.total_mass, np.zeros((K + 1, 3)), np.zeros((K + 1, 3))
    r_nom, _ = nominal_body(g.task, g.tk)
    n_iter = cfg.residual_iterations if cfg.leg_dynamics else 0
    seconds, first = 0.0, None
    for it in range(n_iter + 1):
        sol, legs, qpos_k, qvel_k, qacc_k, eps_k, secs = _nlp_pass(g, mass, fl1, ml1, r_nom, it)
        seconds += secs
        if it == 0:
            # The paper's CoT_NLP: Eq. 3's torques along the first NLP's path with its forces.
            smp = g.smp
            qf, jf, _ = g.wb.inverse(qpos_k[smp], qvel_k[smp], qacc_k[smp], forces=sol.forces[smp])
            first = (sol, legs, eps_k[smp], g.wb.joint_torques(qf, jf))
        Rk = rotation(sol.theta[:K])
        fl1 = _close(fl1[:K] - eps_k[:, :3])
        ml1 = _close(ml1[:K] - np.einsum("kij,kj->ki", Rk, eps_k[:, 3:]))
    return _NLPStage(sol, legs, qpos_k, qvel_k, qacc_k, *first, passes=n_iter, seconds=seconds)


def _nlp_pass(g: _Grid, mass: float, fl1: np.ndarray, ml1: np.ndarray, r_nom: np.ndarray, it: int):
    """One NLP solve and the residual of its solution in the full equations (Eq. 9) on
    every knot."""
    K, geom, task, wb = g.K, g.geom, g.task, g.wb
    prob = SRBProblem(gait=g.gait, mass=mass, inertia=np.asarray(geom.trunk_inertia), speed=task.speed,
                      height=task.height, friction=task.friction, feet=g.feet, f_legs=fl1, m_legs=ml1, k=g.cfg.k,
                      weight=geom.total_mass * GRAVITY)
    sol = SRBNLP(prob).solve(r_nom, polish=g.cfg.polish)
    if not sol.success:
        raise _Infeasible("nlp", sol.constraint_violation,
                          nlp={"success": False, "message": sol.message, "iteration": it})
    legs = leg_motion(wb, g.gait, task, g.tk[:K], sol.r[:K], sol.theta[:K])
    _check_reach(legs)
    qpos_k = wb.qpos(sol.r[:K], sol.theta[:K], legs.q)
    qvel_k = wb.qvec(sol.v[:K], sol.omega[:K], legs.qd)
    qacc_k = wb.qvec(sol.a[:K], sol.alpha[:K], legs.qdd)
    qfrc_k, _, _ = wb.inverse(qpos_k, qvel_k, qacc_k)
    eps_k = qfrc_k[:, :6] - wb.body_wrench_of_forces(sol.r[:K], sol.theta[:K], g.feet[:K], sol.forces[:K])
    return sol, legs, qpos_k, qvel_k, qacc_k, eps_k, sol.seconds


def _forces(g: _Grid, qfrc: np.ndarray, jtf: np.ndarray, f: np.ndarray) -> _Forces:
    """Forces ``f`` (making ``jtf``) against the generalised forces ``qfrc`` the motion needs."""
    return _Forces(f=f, wrench=jtf, eps=qfrc[:, :6] - jtf[:, :6], tau=g.wb.joint_torques(qfrc, jtf))


def _qp(g: _Grid, sol, qfrc: np.ndarray, f_nlp: np.ndarray):
    """The residual QP (Eq. 10): forces nearest the NLP's that leave no residual."""
    _, stance = g.gait.phase(g.ts)
    first, last = _stance_edges(stance)
    R = rotation(sol.theta[g.smp])
    arms = g.feet[g.smp] - sol.r[g.smp][:, None, :]
    f_qp, status = residual_qp(qfrc[:, :6], arms, R, stance, first, last, f_nlp, g.task.friction,
                               g.geom.total_mass * GRAVITY)
    return f_qp, stance, status


def _integrate(g: _Grid, sol, legs, force_at) -> ForwardPath:
    """The full equations integrated from the solution's first knot, the legs on their path,
    the contacts pushing ``force_at(times)``."""
    return integrate(g.wb, g.gait, g.task, g.tk, sol.r[0], quat(sol.theta[:1])[0], sol.v[0], sol.omega[0],
                     force_at, _close(legs.q), _close(legs.qd), _close(legs.qdd),
                     substeps=g.cfg.substeps, passes=g.cfg.forward_passes)


def _final_forces(g: _Grid, fwd: ForwardPath, f_qp: np.ndarray) -> _Forces:
    """The QP forces along the forward check's own path: the final torques."""
    smp, wb = g.smp, g.wb
    qpos_f = wb.qpos(fwd.r[smp], fwd.theta[smp], fwd.q[smp])
    qpos_f[:, 3:7] = fwd.quat[smp]
    qvel_f = wb.qvec(fwd.v[smp], fwd.omega[smp], fwd.qd[smp])
    qacc_f = wb.qvec(fwd.a[smp], fwd.alpha[smp], fwd.qdd[smp])
    qfrc_f, jtf_f, _ = wb.inverse(qpos_f, qvel_f, qacc_f, forces=f_qp)
    return _forces(g, qfrc_f, jtf_f, f_qp)


def _score(g: _Grid, nlp: _NLPStage, at_nlp: _Forces, at_qp: _Forces, final: _Forces, fwd: ForwardPath, w: float,
           w_parts: dict[str, float], qp_status: np.ndarray) -> dict[str, Any]:
    """CoT per stage, Eq. 11's J and the feasibility verdict (penalties ordered as the
    module's docstring says)."""
    smp, dts, mt = g.smp, g.dts, g.geom.total_mass
    d_nlp = g.task.speed * g.T
    d_fwd = float(fwd.r[-1, 0] - fwd.r[0, 0])
    cot = {
        "nlp_first": _cot(nlp.tau_first, nlp.legs_first.qd[smp], dts, mt, d_nlp),
        "nlp": _cot(at_nlp.tau, nlp.legs.qd[smp], dts, mt, d_nlp),
        "qp": _cot(at_qp.tau, nlp.legs.qd[smp], dts, mt, d_nlp),
        "final": _cot(final.tau, fwd.qd[smp], dts, mt, d_fwd),
    }
    jerk = _jerk_term(at_qp.f, dts, g.T)
    feasible = w <= 1.0 and fwd.reach_ok
    if feasible:
        failed, fitness = None, float(cot["final"]["cot"] + g.cfg.jerk_weight * jerk)
    elif not fwd.reach_ok:
        failed, fitness = "ik_reach", _penalty("ik_reach", 0.0)
    else:
        failed, fitness = "periodicity", _penalty("periodicity", w)
    return dict(
        feasible=bool(feasible), failed=failed, fitness=fitness,
        cot={k: v["cot"] for k, v in cot.items()},
        cot_detail=cot,
        jerk_term_N_s=jerk,
        objective_terms={"cot": cot["final"]["cot"], "jerk": g.cfg.jerk_weight * jerk},
        eps={"nlp": _eps(nlp.eps_first), "nlp_iterated": _eps(at_nlp.eps), "qp": _eps(at_qp.eps),
             "final": _eps(final.eps)},
        periodicity_error=w,
        periodicity=w_parts,
        qp_failures=int(qp_status.sum()),
        distance_m=d_fwd,
    )


def _detail(g: _Grid, nlp: _NLPStage, at_nlp: _Forces, at_qp: _Forces, final: _Forces, fwd: ForwardPath,
            stance: np.ndarray, fl: np.ndarray, ml: np.ndarray) -> dict[str, Any]:
    """Every stage's trajectories, and the forward check with the first NLP's own forces
    (how far the paper's single pass is from periodic)."""
    s1, smp, tk = nlp.first, g.smp, g.tk
    fwd_nlp = _integrate(g, s1, nlp.legs_first, lambda times: _interp_forces(tk, s1.forces, times))
    w_nlp, _ = periodicity_error(fwd_nlp, g.task.speed, g.T)
    return {"nlp_forward_periodicity_error": w_nlp, "trajectories": {
        "t_knots": tk, "t_samples": g.ts, "nlp": nlp.sol, "forward_nlp": fwd_nlp, "final": fwd,
        "f_nlp": at_nlp.f, "f_qp": at_qp.f, "eps_nlp": at_nlp.eps, "eps_qp": at_qp.eps, "eps_final": final.eps,
        "tau_nlp": at_nlp.tau, "tau_qp": at_qp.tau, "tau_final": final.tau, "legs_nlp": nlp.legs, "stance": stance,
        "dummy_f_legs": fl, "dummy_m_legs": ml, "wrench_nlp": at_nlp.wrench[:, :6], "wrench_qp": at_qp.wrench[:, :6],
        # The paper's NLP (first pass, dummy legs only): Fig. 3's and Fig. 4's black curves.
        "nlp_first": s1, "f_nlp_first": s1.forces[smp], "eps_nlp_first": nlp.eps_first,
        "wrench_nlp_first": g.wb.body_wrench_of_forces(s1.r[smp], s1.theta[smp], g.feet[smp], s1.forces[smp]),
    }}


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

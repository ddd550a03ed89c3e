"""The contact-force NLP of paper 003 (Eq. 8): SRB + dummy legs, single shooting.

Unknowns: per leg and axis, the k inner control points of a Bernstein polynomial of degree
k+1 over the leg's contact phase (its end points are zero: no force at touchdown and
lift-off), plus the trunk's initial state (y0, z0, v0, theta0, omega0; x0 = 0 by
translation invariance). A leg in contact the whole period (beta = 1) gets a periodic
basis (constant, cos, sin, ...) instead, with no end conditions.

Dynamics (Eq. 5), integrated exactly for a piecewise-linear acceleration between knots:
m a = m g + sum f_i + f_l ; I alpha = sum (p_i - r) x f_i + m_l (small angles, world-aligned I).
The translation is linear in the unknowns; the moments' arms p_i - r(t) make the rotation
bilinear: that is what makes it an NLP.

Constraints: friction (Eq. 6) by the inscribed pyramid |F_x|, |F_y| <= mu/sqrt(2) F_z,
and F_z >= 0, on the control points (a Bernstein curve stays in the convex hull of its
control points, so the whole curve then satisfies them); braking at touchdown and
propulsion at lift-off, dF_x/dt(t_i) < 0 and dF_x/dt(t_i + T_i) < 0 (Fig. 2), as the sign
of the first and last control point; periodicity and averages (Eq. 7 as the papers README
reads it): every trunk coordinate and rate equal at 0 and T except x, x(T) - x(0) = V T,
mean height h, and (our choice, the paper leaves them free) mean lateral position and mean
angles zero so the solution is unique.

Objective: the integrated squared force rate sum_i int |dF_i/dt|^2 dt ("jerk", Eq. 8's
integrand squared so that it is a norm), plus 1e-6/T^2 x int |F|^2 to pick the least
force among equal-jerk solutions (a standing robot is statically indeterminate).

Solver: the linearised problem (moment arms from the constant-speed trunk) is a QP solved
exactly by quadprog; that is the warm start of scipy's SLSQP on the bilinear problem with
analytic gradients.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import quadprog
from scipy.optimize import minimize

from app.jobs.energy.dynamics.gait import Gait

SIGN_MARGIN = 1e-3  # |dF_x/dt| at touchdown / lift-off, in units of weight per contact phase
FZ_MIN = 1e-3  # control points of F_z, in units of weight


@dataclasses.dataclass
class SRBProblem:
    gait: Gait
    mass: float  # SRB mass (trunk alone with dummy legs; whole robot when legs are massless)
    inertia: np.ndarray  # (3,)
    speed: float
    height: float
    friction: float
    feet: np.ndarray  # (K+1, 4, 3) world footholds on the knots (only stance rows matter)
    f_legs: np.ndarray  # (K+1, 3)
    m_legs: np.ndarray  # (K+1, 3)
    k: int = 4
    weight: float = 1.0  # force scale (N), e.g. total m g

    @property
    def n_knots(self) -> int:
        return self.feet.shape[0] - 1


@dataclasses.dataclass
class NLPSolution:
    success: bool
    message: str
    z: np.ndarray
    t: np.ndarray  # (K+1,)
    forces: np.ndarray  # (K+1, 4, 3) N
    force_rate: np.ndarray  # (K+1, 4, 3) N/s
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    jerk: float  # int sum |dF_i/dt|^2 dt  (N^2/s)
    constraint_violation: float
    iterations: int
    seconds: float
    warm_start_violation: float


def _bernstein(n: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Degree-n basis (len(s), n+1) and its d/ds."""
    j = np.arange(n + 1)
    binom = np.array([math.comb(n, i) for i in j], dtype=float)
    s = s[:, None]
    B = binom * s**j * (1 - s) ** (n - j)
    Bm = np.zeros((s.shape[0], n + 2))
    lower = np.array([math.comb(n - 1, i) for i in range(n)], dtype=float) * s ** np.arange(n) * (1 - s) ** (n - 1 - np.arange(n))
    Bm[:, 1:n + 1] = lower
    dB = n * (Bm[:, :n + 1] - Bm[:, 1:n + 2])
    return B, dB


def _integrators(K: int, dt: float):
    """Matrices Qv, Pp (K+1, K+1): v_j = v0 + Qv[j] a, r_j = r0 + v0 t_j + Pp[j] a for an
    acceleration linear between knots; and the trapezoid mean weights (K+1,)."""
    Qv = np.zeros((K + 1, K + 1))
    Pp = np.zeros((K + 1, K + 1))
    for j in range(K):
        Qv[j + 1] = Qv[j]
        Qv[j + 1, j] += dt / 2
        Qv[j + 1, j + 1] += dt / 2
        Pp[j + 1] = Pp[j] + dt * Qv[j]
        Pp[j + 1, j] += dt * dt / 3
        Pp[j + 1, j + 1] += dt * dt / 6
    w = np.full(K + 1, dt)
    w[0] = w[-1] = dt / 2
    return Qv, Pp, w / (K * dt)


class SRBNLP:
    def __init__(self, prob: SRBProblem):
        self.p = prob
        g, K, k = prob.gait, prob.n_knots, prob.k
        T = g.period
        self.T, self.K = T, K
        self.dt = T / K
        self.t = np.arange(K + 1) * self.dt
        self.nc = 4 * 3 * k
        self.nz = self.nc + 11
        # Force basis per leg on the knots (K+1, k) and its time derivative.
        self.Phi, self.dPhi, self.periodic = [], [], []
        for i in range(4):
            beta = g.duty[i]
            tau = np.mod(self.t - g.touchdown[i], T)
            if beta >= 1.0:
                s = tau / T
                cols, dcols = [np.ones_like(s)], [np.zeros_like(s)]
                h = 1
                while len(cols) < k:
                    w = 2 * math.pi * h / T
                    cols += [np.cos(w * tau), np.sin(w * tau)]
                    dcols += [-w * np.sin(w * tau), w * np.cos(w * tau)]
                    h += 1
                self.Phi.append(np.stack(cols[:k], 1))
                self.dPhi.append(np.stack(dcols[:k], 1))
                self.periodic.append(True)
            else:
                Ti = beta * T
                inside = (tau > 0) & (tau < Ti)
                s = np.clip(tau / Ti, 0.0, 1.0)
                B, dB = _bernstein(k + 1, s)
                self.Phi.append(B[:, 1:k + 1] * inside[:, None])
                self.dPhi.append(dB[:, 1:k + 1] * inside[:, None] / Ti)
                self.periodic.append(False)
        self.Qv, self.Pp, self.wmean = _integrators(K, self.dt)
        self.wtrap = self.wmean * T
        self.tmean = float(self.wmean @ self.t)
        W = prob.weight
        # Affine maps from z: forces F_i = dF[i] @ z (K+1, 3, nz), acceleration a = a0 + dA @ z.
        self.dF = np.zeros((4, K + 1, 3, self.nz))
        for i in range(4):
            for ax in range(3):
                c0 = self._cidx(i, ax, 0)
                self.dF[i, :, ax, c0:c0 + k] = W * self.Phi[i]
        self.dFd = np.zeros_like(self.dF)
        for i in range(4):
            for ax in range(3):
                c0 = self._cidx(i, ax, 0)
                self.dFd[i, :, ax, c0:c0 + k] = W * self.dPhi[i]
        self.a0 = np.array([0.0, 0.0, -9.81]) + prob.f_legs / prob.mass
        self.dA = self.dF.sum(axis=0) / prob.mass
        s = self.nc
        # r = r0 + v0 t + Pp a: affine in z.
        self.R0 = np.einsum("jk,kx->jx", self.Pp, self.a0)
        self.dR = np.einsum("jk,kxz->jxz", self.Pp, self.dA)
        self.dR[:, 1, s + 0] += 1.0  # y0
        self.dR[:, 2, s + 1] += 1.0  # z0
        for ax in range(3):
            self.dR[:, ax, s + 2 + ax] += self.t  # v0
        self.V0 = np.einsum("jk,kx->jx", self.Qv, self.a0)
        self.dV = np.einsum("jk,kxz->jxz", self.Qv, self.dA)
        for ax in range(3):
            self.dV[:, ax, s + 2 + ax] += 1.0
        # Objective: sum_i int |dF_i/dt|^2, quadratic in c, in units of W^2.
        H = np.zeros((self.nz, self.nz))
        Hj = np.zeros((self.nz, self.nz))
        reg = 1e-6 / T**2
        for i in range(4):
            for ax in range(3):
                c0 = self._cidx(i, ax, 0)
                sl = slice(c0, c0 + k)
                Hj[sl, sl] += self.dPhi[i].T @ (self.wtrap[:, None] * self.dPhi[i])
                H[sl, sl] += reg * self.Phi[i].T @ (self.wtrap[:, None] * self.Phi[i])
        self.H, self.Hj = H + Hj, Hj
        self.Iinv = 1.0 / np.asarray(prob.inertia, dtype=float)
        self._lin_ineq()

    def _cidx(self, leg: int, axis: int, m: int) -> int:
        return (leg * 3 + axis) * self.p.k + m

    # ---- constraints -----------------------------------------------------------------
    def _lin_ineq(self) -> None:
        """Rows G z >= h for friction, F_z >= 0 and the F_x signs."""
        k, mu = self.p.k, self.p.friction / math.sqrt(2.0)
        rows, rhs = [], []
        for i in range(4):
            if self.periodic[i]:
                # On the knots: the periodic basis has no convex-hull property.
                P = self.Phi[i]
                for j in range(self.K):
                    def row(coefs):
                        r = np.zeros(self.nz)
                        for ax, c in coefs:
                            c0 = self._cidx(i, ax, 0)
                            r[c0:c0 + k] += c * P[j]
                        return r
                    rows += [row([(2, 1.0)]), row([(2, mu), (0, -1.0)]), row([(2, mu), (0, 1.0)]),
                             row([(2, mu), (1, -1.0)]), row([(2, mu), (1, 1.0)])]
                    rhs += [0.0] * 5
                continue
            for m in range(k):
                cx, cy, cz = (self._cidx(i, ax, m) for ax in range(3))
                for coefs, b in (({cz: 1.0}, FZ_MIN), ({cz: mu, cx: -1.0}, 0.0), ({cz: mu, cx: 1.0}, 0.0),
                                 ({cz: mu, cy: -1.0}, 0.0), ({cz: mu, cy: 1.0}, 0.0)):
                    r = np.zeros(self.nz)
                    for idx, c in coefs.items():
                        r[idx] = c
                    rows.append(r)
                    rhs.append(b)
            first, last = self._cidx(i, 0, 0), self._cidx(i, 0, k - 1)
            r = np.zeros(self.nz)
            r[first] = -1.0
            rows.append(r)
            rhs.append(SIGN_MARGIN)  # F_x rises negative: braking
            r = np.zeros(self.nz)
            r[last] = 1.0
            rows.append(r)
            rhs.append(SIGN_MARGIN)  # F_x falls from positive: propulsion
        self.G = np.asarray(rows)
        self.h = np.asarray(rhs)

    def _translation(self):
        """Linear equalities E z = e on the translation (9 rows)."""
        K, T = self.K, self.T
        E, e = [], []
        for ax in range(3):  # v(T) = v(0)
            E.append(self.dV[K, ax] - self.dV[0, ax])
            e.append(-(self.V0[K, ax] - self.V0[0, ax]))
        for ax in range(3):  # r(T) - r(0) = (V T, 0, 0)
            E.append(self.dR[K, ax] - self.dR[0, ax])
            e.append((self.p.speed * T if ax == 0 else 0.0) - (self.R0[K, ax] - self.R0[0, ax]))
        for ax, target in ((1, 0.0), (2, self.p.height)):  # mean y = 0, mean z = h
            E.append(self.wmean @ self.dR[:, ax])
            e.append(target - self.wmean @ self.R0[:, ax])
        return np.asarray(E), np.asarray(e)

    def torque(self, z: np.ndarray, jac: bool = True):
        r = self.R0 + self.dR @ z
        tau = self.p.m_legs.copy()
        dtau = np.zeros((self.K + 1, 3, self.nz)) if jac else None
        for i in range(4):
            F = self.dF[i] @ z
            arm = self.p.feet[:, i] - r
            tau += np.cross(arm, F)
            if jac:
                dtau += np.cross(arm[:, :, None], self.dF[i], axisa=1, axisb=1, axisc=1)
                dtau -= np.cross(self.dR, F[:, :, None], axisa=1, axisb=1, axisc=1)
        return tau, dtau

    def _rotation(self, z: np.ndarray, jac: bool = True):
        """theta(T) - theta(0), omega(T) - omega(0), mean theta (9 values) and d/dz."""
        K, T, s = self.K, self.T, self.nc
        tau, dtau = self.torque(z, jac)
        alpha = tau * self.Iinv
        th0, w0 = z[s + 5:s + 8], z[s + 8:s + 11]
        mPp = self.wmean @ self.Pp
        val = np.concatenate([self.Qv[K] @ alpha, w0 * T + self.Pp[K] @ alpha, th0 + w0 * self.tmean + mPp @ alpha])
        if not jac:
            return val, None
        dal = dtau * self.Iinv[None, :, None]
        J = np.concatenate([np.einsum("k,kxz->xz", self.Qv[K], dal), np.einsum("k,kxz->xz", self.Pp[K], dal),
                            np.einsum("k,kxz->xz", mPp, dal)])
        for ax in range(3):
            J[3 + ax, s + 8 + ax] += T
            J[6 + ax, s + 5 + ax] += 1.0
            J[6 + ax, s + 8 + ax] += self.tmean
        return val, J

    def _rotation_linearised(self, r_ref: np.ndarray):
        """The rotation rows with the moment arms frozen at r_ref: linear, E z = e."""
        K, T, s = self.K, self.T, self.nc
        tau0 = self.p.m_legs.copy()
        dtau = np.zeros((K + 1, 3, self.nz))
        k3 = 3 * self.p.k
        for i in range(4):
            arm = self.p.feet[:, i] - r_ref
            cols = slice(i * k3, (i + 1) * k3)  # leg i's forces depend on its own coefficients only
            F = self.dF[i][:, :, cols]
            ax, ay, az = (arm[:, j, None] for j in range(3))
            dtau[:, 0, cols] += ay * F[:, 2] - az * F[:, 1]
            dtau[:, 1, cols] += az * F[:, 0] - ax * F[:, 2]
            dtau[:, 2, cols] += ax * F[:, 1] - ay * F[:, 0]
        a0, dal = tau0 * self.Iinv, dtau * self.Iinv[None, :, None]
        mPp = self.wmean @ self.Pp
        E = np.concatenate([np.einsum("k,kxz->xz", L, dal) for L in (self.Qv[K], self.Pp[K], mPp)])
        e = -np.concatenate([L @ a0 for L in (self.Qv[K], self.Pp[K], mPp)])
        for ax in range(3):
            E[3 + ax, s + 8 + ax] += T
            E[6 + ax, s + 5 + ax] += 1.0
            E[6 + ax, s + 8 + ax] += self.tmean
        return E, e

    def violation(self, z: np.ndarray) -> float:
        Et, et = self._translation()
        rot, _ = self._rotation(z, jac=False)
        eq = np.concatenate([Et @ z - et, rot])
        ineq = np.minimum(self.G @ z - self.h, 0.0)
        return float(max(np.abs(eq).max(), np.abs(ineq).max(initial=0.0)))

    # ---- solve -----------------------------------------------------------------------
    def warm_start(self, r_ref: np.ndarray, max_sweeps: int = 8, tol: float = 1e-9) -> tuple[np.ndarray, int]:
        """The QP with frozen moment arms, re-linearised about its own trunk path until the
        bilinear constraints hold to ``tol`` (each sweep shrinks the violation ~100x)."""
        Et, et = self._translation()
        Gq = self.H + 1e-9 * np.eye(self.nz)
        z = None
        for sweep in range(1, max_sweeps + 1):
            Er, er = self._rotation_linearised(r_ref)
            C = np.concatenate([Et, Er, self.G]).T
            b = np.concatenate([et, er, self.h])
            z = quadprog.solve_qp(Gq, np.zeros(self.nz), C, b, len(et) + len(er))[0]
            r_ref = self.R0 + self.dR @ z
            if self.violation(z) < tol:
                break
        return z, sweep

    def solve(self, r_ref: np.ndarray, maxiter: int = 60, polish: bool = True) -> NLPSolution:
        t0 = time.perf_counter()
        try:
            z0, sweeps = self.warm_start(r_ref)
        except ValueError as e:  # quadprog: constraints inconsistent
            return self._failed(f"linearised QP infeasible: {e}", t0)
        warm_viol = self.violation(z0)
        Et, et = self._translation()
        z, nit, ok, msg = z0, sweeps, True, f"linearised QP, {sweeps} sweeps"
        if polish:
            cons = [
                {"type": "eq", "fun": lambda z: Et @ z - et, "jac": lambda z: Et},
                {"type": "eq", "fun": lambda z: self._rotation(z, False)[0], "jac": lambda z: self._rotation(z)[1]},
                {"type": "ineq", "fun": lambda z: self.G @ z - self.h, "jac": lambda z: self.G},
            ]
            res = minimize(lambda z: z @ self.H @ z, z0, jac=lambda z: 2 * self.H @ z, method="SLSQP",
                           constraints=cons, options={"maxiter": maxiter, "ftol": 1e-12})
            nit, msg = int(res.nit), str(res.message)
            if self.violation(res.x) <= max(warm_viol, 1e-9) * 1.0001 or res.success:
                z, ok = res.x, bool(res.success)
            else:
                ok = False
        viol = self.violation(z)
        sol = self._trajectory(z, ok and viol < 1e-6, msg, nit, time.perf_counter() - t0, viol)
        sol.warm_start_violation = warm_viol
        return sol

    def _failed(self, msg: str, t0: float) -> NLPSolution:
        z = np.zeros(self.nz)
        return self._trajectory(z, False, msg, 0, time.perf_counter() - t0, float("inf"))

    def _trajectory(self, z, success, msg, nit, seconds, viol) -> NLPSolution:
        s = self.nc
        r = self.R0 + self.dR @ z
        v = self.V0 + self.dV @ z
        a = self.a0 + self.dA @ z
        tau, _ = self.torque(z, jac=False)
        alpha = tau * self.Iinv
        th0, w0 = z[s + 5:s + 8], z[s + 8:s + 11]
        omega = w0 + self.Qv @ alpha
        theta = th0 + np.outer(self.t, w0) + self.Pp @ alpha
        F = np.stack([self.dF[i] @ z for i in range(4)], axis=1)
        Fd = np.stack([self.dFd[i] @ z for i in range(4)], axis=1)
        jerk = float(self.p.weight**2 * z @ self.Hj @ z)
        return NLPSolution(success=success, message=msg, z=z, t=self.t, forces=F, force_rate=Fd, r=r, v=v, a=a,
                           theta=theta, omega=omega, alpha=alpha, jerk=jerk, constraint_violation=viol,
                           iterations=nit, seconds=seconds, warm_start_violation=float("nan"))

"""Recovery geometry (paper 002 Sec. 4.1-4.2): which swing leg catches the robot, where it
lands (reachable space on the fitted ground, Eq. 10-14), and its quintic swing.

Leg model (Eq. 1-2): in the mirrored coxa frame of a leg (y outward, z up) the foot is the
point (L1, -d) turned by the swing angle theta about x, with d = K_z J_z + L2 the leg length
and an independent horizontal travel x = K_x J_x. Everything here is in the body frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.robots.pantograph import LegWorkspace, leg_fk, leg_ik, reachable  # noqa: F401  (leg_fk: the tests')
from app.jobs.tipping.stability.polygon import cross3


@dataclasses.dataclass
class ReachableSpace:
    leg: int
    H: np.ndarray
    L: np.ndarray
    R: np.ndarray
    corners: dict[str, np.ndarray]  # A, B (at L), C, D (at R): front/back ends

    def points(self) -> dict[str, np.ndarray]:
        return {"L": self.L, "R": self.R, **self.corners}


def reachable_space(ws: LegWorkspace, normal: np.ndarray, origin: np.ndarray, rho: float = 0.9,
                    samples: int = 801) -> ReachableSpace | None:
    """Approximate reachable space of a foot on the fitted ground (Eq. 10-13). H is the hip
    projected on the ground along body z; L and R are the inner/outer ends of the ground
    line through H normal to x_C inside the leg plane (found on a dense grid instead of the
    law of sines and cosines, which gives the same ends with the swing-angle limit
    applied exactly); rho pulls them toward H (Eq. 11-12); A..D add the horizontal travel
    projected on the ground (Eq. 13). None when the ground is out of reach (|B H| > L_max)."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    B = np.asarray(ws.hip, float)
    ez = np.array([0.0, 0.0, 1.0])
    if abs(n[2]) < 1e-6:
        return None
    t = -(n @ (B - origin)) / n[2]
    H = B + t * ez
    if np.linalg.norm(H - B) > ws.l_max:
        return None
    u = cross3(n, np.array([1.0, 0.0, 0.0]))  # in the ground plane, normal to x_C, toward +y
    u /= np.linalg.norm(u)
    u *= ws.side  # outward
    s = np.linspace(-ws.l_max * 1.5, ws.l_max * 1.5, samples)
    pts = H + s[:, None] * u
    j = leg_ik(ws, pts)
    ok = reachable(ws, np.zeros_like(s), j[:, 1], j[:, 2])
    if not ok.any():
        return None
    s_in, s_out = s[ok].min(), s[ok].max()
    if s_in <= 0.0 <= s_out:  # Eq. 11-12: scale about H
        s_in, s_out = rho * s_in, rho * s_out
    else:  # H itself out of reach: shrink the interval about its middle instead
        mid = 0.5 * (s_in + s_out)
        s_in, s_out = mid + rho * (s_in - mid), mid + rho * (s_out - mid)
    L, R = H + s_in * u, H + s_out * u
    P = np.eye(3) - np.outer(n, n)
    fwd = rho * P @ np.array([ws.x_range[1], 0.0, 0.0])  # Eq. 13
    back = rho * P @ np.array([ws.x_range[0], 0.0, 0.0])
    corners = {"A": L + fwd, "B": L + back, "C": R + fwd, "D": R + back}
    return ReachableSpace(leg=ws.leg, H=H, L=L, R=R, corners=corners)


def side_of_axis(points: np.ndarray, p_i: np.ndarray, p_j: np.ndarray, z: np.ndarray = np.array([0.0, 0.0, 1.0])) -> np.ndarray:
    """Eq. 14 turned into a signed distance: Theta / |p_j - p_i| with Theta = (A - p_i) x
    (p_j - p_i) . z. Positive on the right of the CCW tipping axis, i.e. outside the
    support polygon, where a foot gains lever arm against the tip."""
    e = np.asarray(p_j, float) - np.asarray(p_i, float)
    r = np.asarray(points, float) - np.asarray(p_i, float)
    return cross3(r, e) @ z / np.linalg.norm(e - z * (e @ z))


def optimal_foothold(space: ReachableSpace, p_i: np.ndarray, p_j: np.ndarray,
                     parallel_deg: float = 15.0) -> tuple[str, np.ndarray, float]:
    """Sec. 4.2: largest lever arm about the tipping axis. When the reach boundaries AB/CD
    run within ``parallel_deg`` of the axis, L or R (the boundary's middle: shorter swing,
    same lever arm) is taken; otherwise the farthest boundary point. Ties go to the right
    of the axis (Eq. 14). Returns (label, point, signed lever arm)."""
    pts = space.points()
    e = np.asarray(p_j, float) - np.asarray(p_i, float)
    e[2] = 0.0
    xdir = space.corners["A"] - space.corners["B"]
    xdir[2] = 0.0
    ang = np.degrees(np.arccos(min(1.0, abs(e @ xdir) / max(np.linalg.norm(e) * np.linalg.norm(xdir), 1e-12))))
    labels = ["L", "R"] if ang < parallel_deg else ["A", "B", "C", "D", "L", "R"]
    dist = side_of_axis(np.stack([pts[k] for k in labels]), p_i, p_j)
    k = int(np.argmax(dist))
    return labels[k], pts[labels[k]], float(dist[k])


def select_adjustment_leg(edge: tuple[np.ndarray, np.ndarray], candidates: dict[int, ReachableSpace | None]) -> tuple[int | None, float]:
    """The rule behind Table II (its marks are missing from the copy): the swing leg that can
    put its foot farthest outside the tipping axis, i.e. the largest restoring lever arm.
    On the tripod's side edge this is the middle leg of that side, on a diagonal edge the
    corner leg beyond it (a13->2, a35->6, a51->4, a24->1, a46->5, a62->3 on the nominal
    stance). Returns (leg or None, its lever arm)."""
    best, best_d = None, -np.inf
    for leg, space in sorted(candidates.items()):
        if space is None:
            continue
        d = float(np.max(side_of_axis(np.stack(list(space.points().values())), *edge)))
        if d > best_d + 1e-9:
            best, best_d = leg, d
    return best, best_d


# -- quintic swing -----------------------------------------------------------------------

def quintic_coeffs(p0, v0, a0, p1, v1, a1, T: float) -> np.ndarray:
    """Coefficients c (6, dim) of p(t) = sum c_k t^k meeting position, velocity and
    acceleration at t = 0 and t = T (Sec. 4.2)."""
    p0, v0, a0, p1, v1, a1 = (np.atleast_1d(np.asarray(v, float)) for v in (p0, v0, a0, p1, v1, a1))
    T2, T3, T4, T5 = T ** 2, T ** 3, T ** 4, T ** 5
    M = np.array([[T3, T4, T5], [3 * T2, 4 * T3, 5 * T4], [6 * T, 12 * T2, 20 * T3]])
    rhs = np.stack([p1 - (p0 + v0 * T + 0.5 * a0 * T2), v1 - (v0 + a0 * T), a1 - a0])
    c345 = np.linalg.solve(M, rhs)
    return np.vstack([p0, v0, 0.5 * a0, c345])


def quintic_eval(c: np.ndarray, t: np.ndarray, deriv: int = 0) -> np.ndarray:
    t = np.atleast_1d(np.asarray(t, float))
    k = np.arange(6)
    if deriv == 0:
        basis = t[:, None] ** k
    elif deriv == 1:
        basis = np.where(k > 0, k * t[:, None] ** np.maximum(k - 1, 0), 0.0)
    else:
        basis = np.where(k > 1, k * (k - 1) * t[:, None] ** np.maximum(k - 2, 0), 0.0)
    return basis @ c


@dataclasses.dataclass
class SwingPlan:
    """Quintic from the foot's state at detection to the target foothold, landing at rest,
    plus a clearance bump h 64 s^3 (1-s)^3 along the ground normal (zero velocity and
    acceleration at both ends, so the landing conditions are untouched)."""

    coeffs: np.ndarray
    duration: float
    clearance: float
    normal: np.ndarray

    @classmethod
    def plan(cls, p0, v0, a0, target, duration: float, clearance: float, normal) -> SwingPlan:
        z = np.zeros(3)
        return cls(quintic_coeffs(p0, v0, a0, target, z, z, duration), float(duration), float(clearance),
                   np.asarray(normal, float))

    def at(self, t: np.ndarray) -> np.ndarray:
        t = np.clip(np.atleast_1d(np.asarray(t, float)), 0.0, self.duration)
        s = t / self.duration
        bump = self.clearance * 64.0 * s ** 3 * (1 - s) ** 3
        return quintic_eval(self.coeffs, t) + bump[:, None] * self.normal

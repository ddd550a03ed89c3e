"""Foot-force distribution with stability (paper 002 Sec. 4.3, Eq. 16-24), solved with
quadprog (Goldfarb-Idnani dual active set: dense, exact, ~tens of microseconds at this size).

The copy's Eq. 19-24 are garbled; implemented intent (papers README): for every edge i of
the support polygon the FASM tipping force f_i* = f_ri + f_ni (Eq. 5-7) is linear in the
stacked foot forces x, f_i* = -V_i x with
    V_i = (1 - a a^T)[E ... E] + [l_i^]x (a a^T)[T_1 ... T_k] / |l_i|,   T_j = [p_j - p_G]x
(the copy drops the cross product with l_i^ that Eq. 6 has). f_i* must stay inside the
pyramid inscribed in the stability cone whose apex is the CoG and whose base is the circle of
radius lambda d_min about the support polygon's centroid G_s (Eq. 21-22): along the body x
and y directions projected on the ground (T_1..T_4) with half-angles alpha_1..alpha_4,
|f*.u| <= tan(alpha)/sqrt(2) f*.g (Eq. 24's 1/sqrt(2) is the inscribed square pyramid).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import quadprog

from app.jobs.tipping.stability.polygon import ccw_order, cross3, edge_frames, polygon_centroid, tangent_basis

SQRT2 = np.sqrt(2.0)


def skew(v: np.ndarray) -> np.ndarray:
    """[v]x for (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, float)
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


@dataclasses.dataclass(frozen=True)
class QPWeights:
    S: tuple[float, ...] = (1.0, 1.0, 1.0, 10.0, 10.0, 10.0)  # wrench tracking (force, moment)
    kappa: float = 1e-3  # Eq. 17's weight of the force-magnitude term x^T W x (W = identity)


@dataclasses.dataclass
class ForceSolution:
    forces: np.ndarray  # (k, 3) ground forces on the robot, world frame
    stability_constrained: bool  # False when the FASM pyramid made the problem infeasible and was dropped
    wrench_error: np.ndarray  # A x - b
    cone_alpha_deg: np.ndarray  # alpha_1..alpha_4
    constraint_matrix: np.ndarray  # C^T x >= lower, every hard constraint that was imposed
    constraint_lower: np.ndarray
    n_friction_rows: int


def stability_rows(feet: np.ndarray, com: np.ndarray, body_x: np.ndarray, normal: np.ndarray,
                   lam: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """Rows G (4 * edges, 3k) with G x >= 0 iff every edge's f_i* is in the inscribed FASM
    pyramid (Eq. 19-24). Feet in any order; the polygon is their CCW hull. Also returns the
    four cone half-angles."""
    feet = np.asarray(feet, float)
    com = np.asarray(com, float)
    k = len(feet)
    hull = ccw_order(feet, normal)
    poly = feet[hull]
    a, l = edge_frames(poly, com)
    ln = np.linalg.norm(l, axis=1)
    lh = l / ln[:, None]
    Gs = polygon_centroid(poly, normal)
    # Eq. 21: smallest distance from G_s to an edge line, within the ground plane.
    e = np.roll(poly, -1, axis=0) - poly
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    r = Gs - poly
    d_min = float(np.min(np.linalg.norm(r - e * np.sum(r * e, axis=1, keepdims=True), axis=1)))
    g = Gs - com
    g /= np.linalg.norm(g)
    ex = np.asarray(body_x, float) - normal * (np.asarray(body_x, float) @ normal)
    ex /= np.linalg.norm(ex)
    ey = cross3(normal, ex)
    T = Gs + lam * d_min * np.stack([ex, ey, -ex, -ey])  # T_1..T_4
    rT = T - com
    cosal = np.abs(rT @ g) / np.linalg.norm(rT, axis=1)
    tan_al = np.sqrt(np.maximum(1.0 - cosal ** 2, 0.0)) / cosal  # Eq. 22
    u1 = ex - g * (ex @ g)
    u1 /= np.linalg.norm(u1)
    u2 = cross3(g, u1)
    # Pyramid faces in f* space: (tan(alpha)/sqrt2) g -/+ u  . f* >= 0, f* = -V_i x.
    faces = np.stack([tan_al[0] / SQRT2 * g - u1, tan_al[1] / SQRT2 * g - u2,
                      tan_al[2] / SQRT2 * g + u1, tan_al[3] / SQRT2 * g + u2])
    # faces . V_i x, expanded so no (m, 3, 3k) tensor is built: with P = F (1 - a a^T),
    # F V_i = [P ... P] + (F (l^ x a) / |l|) (a x r_1, ..., a x r_k), r_j = p_j - p_G,
    # because a^T [r_j]x y = (a x r_j) . y.
    P = faces[None, :, :] - (faces @ a.T).T[:, :, None] * a[:, None, :]  # (m, 4, 3)
    w = (faces @ cross3(lh, a).T).T / ln[:, None]  # (m, 4)
    r = feet - com
    ar = cross3(a[:, None, :], r[None, :, :]).reshape(len(a), 3 * k)  # (m, 3k)
    rows = -(np.tile(P, (1, 1, k)) + w[:, :, None] * ar[:, None, :]).reshape(-1, 3 * k)
    return rows, np.degrees(np.arctan(tan_al))


def distribute(feet: np.ndarray, com: np.ndarray, mass: float, gravity: np.ndarray = np.array([0.0, 0.0, -9.81]),
               acc: np.ndarray | None = None, moment: np.ndarray | None = None, normal: np.ndarray = np.array([0.0, 0.0, 1.0]),
               mu: float = 0.8, fz_max_factor: float = 1.5, lam: float = 0.9, body_x: np.ndarray = np.array([1.0, 0.0, 0.0]),
               weights: QPWeights = QPWeights(), stability: bool = True) -> ForceSolution:
    """Eq. 16-18: forces x on the k stance feet that best produce the body wrench b (support
    of gravity plus the desired acceleration, Eq. 16) with minimum magnitude, subject to
    unilateral contact, the friction pyramid inscribed in mu (ref. 37), an upper bound
    fz_max_factor * m g per foot, and, if ``stability``, the FASM pyramid (Eq. 24). Solved
    in units of m g for conditioning."""
    feet = np.asarray(feet, float)
    com = np.asarray(com, float)
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    k = len(feet)
    mg = mass * float(np.linalg.norm(gravity))
    acc = np.zeros(3) if acc is None else np.asarray(acc, float)
    moment = np.zeros(3) if moment is None else np.asarray(moment, float)
    b = np.concatenate([mass * (acc - gravity), moment]) / mg
    A = np.vstack([np.tile(np.eye(3), (1, k)), np.concatenate(list(skew(feet - com)), axis=1)])
    S = np.diag(weights.S)
    U = 2.0 * A.T @ S @ A + 2.0 * weights.kappa * np.eye(3 * k)
    q = 2.0 * A.T @ S @ b  # quadprog maximises q.x - x^T U x / 2, i.e. f = -q in Eq. 18
    t1, t2 = tangent_basis(normal)
    mu_p = mu / SQRT2
    per_foot = np.stack([normal, -normal, mu_p * normal - t1, mu_p * normal + t1, mu_p * normal - t2, mu_p * normal + t2])
    lower_foot = np.array([0.0, -fz_max_factor, 0.0, 0.0, 0.0, 0.0])
    C = np.zeros((6 * k, 3 * k))
    for j in range(k):
        C[6 * j:6 * j + 6, 3 * j:3 * j + 3] = per_foot
    lo = np.tile(lower_foot, k)
    n_fric = len(lo)
    alpha = np.full(4, np.nan)
    used_stab = False
    if stability:
        rows, alpha = stability_rows(feet, com, body_x, normal, lam)
        try:
            x = quadprog.solve_qp(U, q, np.vstack([C, rows]).T, np.concatenate([lo, np.zeros(len(rows))]), 0)[0]
            C, lo, used_stab = np.vstack([C, rows]), np.concatenate([lo, np.zeros(len(rows))]), True
        except ValueError:  # "constraints are inconsistent": keep the robot supported, report it
            x = None
    if not used_stab:
        x = quadprog.solve_qp(U, q, C.T, lo, 0)[0]
    return ForceSolution(forces=x.reshape(k, 3) * mg, stability_constrained=used_stab, wrench_error=(A @ x - b) * mg,
                         cone_alpha_deg=alpha, constraint_matrix=C, constraint_lower=lo * mg, n_friction_rows=n_fric)

"""Residual removal (paper 003, Eq. 9-10): the contact forces that make the full multibody
trunk equations hold along the NLP's trunk and leg paths.

Time-discretised: one small QP per sample, over the tip forces of the legs in contact then.
Objective (Eq. 10's H, F): || D (J_b^T f - b) ||^2 + lam || (f - f_NLP) / W ||^2, where
b = the trunk rows of mj_inverse (what the contacts must supply) and D scales forces by the
weight W and moments by W x 0.3 m; lam = 1e-6 keeps the NLP's force shape wherever the six
trunk equations leave freedom (one, three or four legs in contact) and makes the QP
strictly convex. Inequalities (A f <= b): F_z >= 0, the inscribed friction pyramid
|F_x|, |F_y| <= mu/sqrt(2) F_z (the NLP's linearised cone), braking F_x <= 0 at a leg's
first sample after touchdown and propulsion F_x >= 0 at its last before lift-off (the
discrete form of the Fig. 2 signs, since the force is zero at both ends). The equations
are a penalty rather than hard equalities because at the instants when the friction cone
binds they cannot all hold; the report says how far they miss (eps_QP), per axis.
Solver: quadprog (dense Goldfarb-Idnani; 6-12 unknowns per sample).
"""

from __future__ import annotations

import math

import numpy as np
import quadprog

LAMBDA = 1e-6
ARM = 0.3  # m: moment scale of the residual's torque rows


def residual_qp(b: np.ndarray, arms: np.ndarray, R: np.ndarray, stance: np.ndarray, first: np.ndarray,
                last: np.ndarray, f_ref: np.ndarray, friction: float, weight: float) -> tuple[np.ndarray, np.ndarray]:
    """Forces (S, 4, 3) per sample and the QP status per sample (S,) (0 ok, 1 failed: NLP kept).

    b (S, 6) trunk generalised force to supply; arms (S, 4, 3) tip minus CoM (world);
    R (S, 3, 3) trunk rotation; stance/first/last (S, 4) masks; f_ref (S, 4, 3) the NLP forces.
    """
    S = b.shape[0]
    out = np.zeros((S, 4, 3))
    status = np.zeros(S, dtype=int)
    mu = friction / math.sqrt(2.0)
    dscale = np.array([1.0] * 3 + [1.0 / ARM] * 3) / weight
    for s in range(S):
        legs = np.flatnonzero(stance[s])
        if legs.size == 0:
            continue
        n = 3 * legs.size
        A = np.zeros((6, n))
        for j, i in enumerate(legs):
            A[0:3, 3 * j:3 * j + 3] = np.eye(3)
            a = arms[s, i]
            skew = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            A[3:6, 3 * j:3 * j + 3] = R[s].T @ skew
        Ad = A * dscale[:, None]
        bd = b[s] * dscale
        fr = f_ref[s, legs].ravel()
        G = 2 * (Ad.T @ Ad + LAMBDA * np.eye(n) / weight**2)
        q = 2 * (Ad.T @ bd + LAMBDA * fr / weight**2)
        C, h = [], []
        for j, i in enumerate(legs):
            x, y, z = 3 * j, 3 * j + 1, 3 * j + 2
            for coefs in ({z: 1.0}, {z: mu, x: -1.0}, {z: mu, x: 1.0}, {z: mu, y: -1.0}, {z: mu, y: 1.0}):
                row = np.zeros(n)
                for idx, c in coefs.items():
                    row[idx] = c
                C.append(row)
                h.append(0.0)
            if first[s, i]:
                row = np.zeros(n)
                row[x] = -1.0
                C.append(row)
                h.append(0.0)
            if last[s, i]:
                row = np.zeros(n)
                row[x] = 1.0
                C.append(row)
                h.append(0.0)
        try:
            f = quadprog.solve_qp(G, q, np.asarray(C).T, np.asarray(h), 0)[0]
        except ValueError:
            status[s] = 1
            f = fr
        out[s, legs] = f.reshape(-1, 3)
    return out, status

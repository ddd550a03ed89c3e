"""Per-step fast paths of the tipping controller, in scalar Python.

A control step sees at most six feet; numpy spends microseconds per call on arrays that
small, and the batched reference (``fasm_edges``, ``ssm``, ``nesm``, ``distribute``) makes
dozens of calls. These functions compute the same numbers with plain floats (tested
against the reference) so FASM + judgment + QP fit in the 1 ms budget on one core.
"""

from __future__ import annotations

import math

import numpy as np
import quadprog

from app.jobs.tipping.stability.polygon import hull_ccw
from app.jobs.tipping.stability.qp import SQRT2, ForceSolution, QPWeights


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def _unit(a):
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def margins(feet: list, forces: list, com, poly: list[int]):
    """FASM per edge (deg, Eq. 3-9), SSM (m) and NESM (m) over the polygon ``poly`` (CCW
    indices into ``feet``); Eq. 4's net wrench from every foot's force. Gravity is -z.
    Returns (fasm per edge, ssm, nesm)."""
    fr = [0.0, 0.0, 0.0]
    nr = [0.0, 0.0, 0.0]
    for p, f in zip(feet, forces):
        if f[0] == 0.0 and f[1] == 0.0 and f[2] == 0.0:
            continue
        r = _sub(p, com)
        m = _cross(r, f)
        for j in range(3):
            fr[j] -= f[j]
            nr[j] -= m[j]
    k = len(poly)
    th, s_min, e_min = [], math.inf, math.inf
    for i in range(k):
        p, q = feet[poly[i]], feet[poly[(i + 1) % k]]
        a = _unit(_sub(q, p))
        d = _sub(q, com)
        l = _sub(d, _scale(a, _dot(a, d)))
        ln = math.sqrt(_dot(l, l))
        lh = _scale(l, 1.0 / ln)
        fi = _sub(fr, _scale(a, _dot(a, fr)))
        ni = _scale(a, _dot(a, nr))
        c = _cross(lh, ni)
        fs = (fi[0] + c[0] / ln, fi[1] + c[1] / ln, fi[2] + c[2] / ln)
        fn = math.sqrt(_dot(fs, fs)) or 1e-12
        cosang = max(-1.0, min(1.0, _dot(lh, fs) / fn))
        ang = math.degrees(math.acos(cosang))
        th.append(ang if _dot(_cross(lh, fs), a) > 0.0 else -ang)
        # SSM: distance in the horizontal plane, positive inside.
        ex, ey = q[0] - p[0], q[1] - p[1]
        eh = math.hypot(ex, ey)
        s = ((com[0] - p[0]) * -ey + (com[1] - p[1]) * ex) / eh
        s_min = min(s_min, s)
        # NESM: rise of the CoM turning about the edge until it is above it.
        h = ln * math.sqrt(max(0.0, 1.0 - a[2] * a[2])) + l[2]
        e_min = min(e_min, h if s >= 0 else -h)
    return th, s_min, e_min


def plane_normal(points: list) -> tuple[float, float, float]:
    """Least-squares plane z = a x + b y + c (normal equations, Cramer's rule)."""
    n = len(points)
    sx = sum(p[0] for p in points)
    sy = sum(p[1] for p in points)
    sz = sum(p[2] for p in points)
    sxx = sum(p[0] * p[0] for p in points)
    syy = sum(p[1] * p[1] for p in points)
    sxy = sum(p[0] * p[1] for p in points)
    sxz = sum(p[0] * p[2] for p in points)
    syz = sum(p[1] * p[2] for p in points)
    M = ((sxx, sxy, sx), (sxy, syy, sy), (sx, sy, float(n)))
    rhs = (sxz, syz, sz)

    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))

    D = det(M)
    cols = []
    for j in range(2):
        mj = [list(r) for r in M]
        for i in range(3):
            mj[i][j] = rhs[i]
        cols.append(det(mj) / D)
    return _unit((-cols[0], -cols[1], 1.0))


def _wrench_map(r: list) -> np.ndarray:
    """A of Eq. 16: the stacked foot forces to the net force and moment about the CoM."""
    A = np.zeros((6, 3 * len(r)))
    for j, rj in enumerate(r):
        c = 3 * j
        A[0, c] = A[1, c + 1] = A[2, c + 2] = 1.0
        A[3, c + 1], A[3, c + 2] = -rj[2], rj[1]
        A[4, c], A[4, c + 2] = rj[2], -rj[0]
        A[5, c], A[5, c + 1] = -rj[1], rj[0]
    return A


def _cost(A: np.ndarray, b: np.ndarray, weights: QPWeights) -> tuple[np.ndarray, np.ndarray]:
    """quadprog's (G, a) of the weighted wrench error plus the force regulariser."""
    AS = A.T * np.asarray(weights.S)
    U = 2.0 * AS @ A
    U[np.diag_indices(A.shape[1])] += 2.0 * weights.kappa
    return U, 2.0 * AS @ b


def _friction_rows(normal, mu: float, fz_max_factor: float, k: int) -> tuple[list[list[float]], list[float]]:
    """Per foot: a normal force between 0 and ``fz_max_factor`` (in units of the weight) and
    the friction pyramid inscribed in the cone of ``mu``."""
    ax = (1.0, 0.0, 0.0) if abs(normal[0]) < 0.9 else (0.0, 1.0, 0.0)
    t1 = _unit(_sub(ax, _scale(normal, _dot(ax, normal))))
    t2 = _cross(normal, t1)
    mp = mu / SQRT2
    per_foot = [normal, _scale(normal, -1.0), _sub(_scale(normal, mp), t1), tuple(mp * n + t for n, t in zip(normal, t1)),
                _sub(_scale(normal, mp), t2), tuple(mp * n + t for n, t in zip(normal, t2))]
    rows: list[list[float]] = []
    lo: list[float] = []
    for j in range(k):
        for i, v in enumerate(per_foot):
            row = [0.0] * (3 * k)
            row[3 * j:3 * j + 3] = v
            rows.append(row)
            lo.append(-fz_max_factor if i == 1 else 0.0)
    return rows, lo


def _centroid_and_inradius(P: list, normal) -> tuple[tuple[float, float, float], float]:
    """The support polygon's centroid G_s (triangle fan) and d_min, its distance to the
    nearest edge (Eq. 21)."""
    m = len(P)
    area, cx, cy, cz = 0.0, 0.0, 0.0, 0.0
    for i in range(1, m - 1):
        w = _dot(_cross(_sub(P[i], P[0]), _sub(P[i + 1], P[0])), normal) * 0.5
        area += w
        cx += w * (P[0][0] + P[i][0] + P[i + 1][0]) / 3
        cy += w * (P[0][1] + P[i][1] + P[i + 1][1]) / 3
        cz += w * (P[0][2] + P[i][2] + P[i + 1][2]) / 3
    Gs = (cx / area, cy / area, cz / area)
    d_min = math.inf
    for i in range(m):
        e = _unit(_sub(P[(i + 1) % m], P[i]))
        rr = _sub(Gs, P[i])
        perp = _sub(rr, _scale(e, _dot(rr, e)))
        d_min = min(d_min, math.sqrt(_dot(perp, perp)))
    return Gs, d_min


def _cone_faces(Gs, d_min: float, com, normal, lam: float, body_x) -> tuple[list[float], list]:
    """The stability cone about the CoM-to-G_s axis (Eq. 21-22): the tangent of its half
    angle toward +x, +y, -x, -y of the body in the ground plane, and its four face normals."""
    gax = _unit(_sub(Gs, com))
    ex = _unit(_sub(body_x, _scale(normal, _dot(body_x, normal))))
    ey = _cross(normal, ex)
    tans = []
    for dvec in (ex, ey, _scale(ex, -1.0), _scale(ey, -1.0)):
        rT = _sub((Gs[0] + lam * d_min * dvec[0], Gs[1] + lam * d_min * dvec[1], Gs[2] + lam * d_min * dvec[2]), com)
        ca = abs(_dot(rT, gax)) / math.sqrt(_dot(rT, rT))
        tans.append(math.sqrt(max(0.0, 1.0 - ca * ca)) / ca)
    u1 = _unit(_sub(ex, _scale(gax, _dot(ex, gax))))
    u2 = _cross(gax, u1)
    faces = [_sub(_scale(gax, tans[0] / SQRT2), u1), _sub(_scale(gax, tans[1] / SQRT2), u2),
             tuple(x + y for x, y in zip(_scale(gax, tans[2] / SQRT2), u1)),
             tuple(x + y for x, y in zip(_scale(gax, tans[3] / SQRT2), u2))]
    return tans, faces


def _edge_rows(P: list, com, r: list, faces: list) -> list[list[float]]:
    """Per support edge and cone face: the FASM force about that edge (Eq. 4-6 with the
    stacked foot forces) kept inside the face (Eq. 23-24)."""
    m = len(P)
    rows = []
    for i in range(m):
        a = _unit(_sub(P[(i + 1) % m], P[i]))
        d = _sub(P[(i + 1) % m], com)
        l = _sub(d, _scale(a, _dot(a, d)))
        ln = math.sqrt(_dot(l, l))
        la = _cross(_scale(l, 1.0 / ln), a)
        ar = [_cross(a, rj) for rj in r]
        for fc in faces:
            fa = _dot(fc, a)
            Pf = (fc[0] - fa * a[0], fc[1] - fa * a[1], fc[2] - fa * a[2])
            w = _dot(fc, la) / ln
            row = []
            for arj in ar:
                row += [-(Pf[0] + w * arj[0]), -(Pf[1] + w * arj[1]), -(Pf[2] + w * arj[2])]
            rows.append(row)
    return rows


def _stability_rows(feet: list, com, normal, lam: float, body_x, r: list) -> tuple[np.ndarray, list[list[float]]]:
    """The stability-cone constraints (Eq. 21-24) and the cone's half angles (deg)."""
    pts = [(p[0] - normal[0] * _dot(p, normal), p[1] - normal[1] * _dot(p, normal)) for p in feet]
    P = [feet[i] for i in hull_ccw(pts)]
    Gs, d_min = _centroid_and_inradius(P, normal)
    tans, faces = _cone_faces(Gs, d_min, com, normal, lam, body_x)
    return np.degrees(np.arctan(np.array(tans))), _edge_rows(P, com, r, faces)


def _solve(U: np.ndarray, q: np.ndarray, rows: list, lo: list, stab_rows: list):
    """With the stability cone if it leaves a feasible QP, else with friction alone.
    Returns (x, whether the cone was used, C, lower bounds)."""
    if stab_rows:
        C = np.array(rows + stab_rows)
        low = np.array(lo + [0.0] * len(stab_rows))
        try:
            return quadprog.solve_qp(U, q, C.T, low, 0)[0], True, C, low
        except ValueError:
            pass
    C, low = np.array(rows), np.array(lo)
    return quadprog.solve_qp(U, q, C.T, low, 0)[0], False, C, low


def distribute_fast(feet: list, com, mass: float, gravity=(0.0, 0.0, -9.81), normal=(0.0, 0.0, 1.0), mu: float = 0.8,
                    fz_max_factor: float = 1.5, lam: float = 0.9, body_x=(1.0, 0.0, 0.0),
                    weights: QPWeights = QPWeights(), stability: bool = True, acc=(0.0, 0.0, 0.0),
                    moment=(0.0, 0.0, 0.0)) -> ForceSolution:
    """``qp.distribute`` with the geometry in floats and the matrices assembled once."""
    k = len(feet)
    g = math.sqrt(_dot(gravity, gravity))
    mg = mass * g
    normal = _unit(normal)
    b = np.array([(acc[0] - gravity[0]) / g, (acc[1] - gravity[1]) / g, (acc[2] - gravity[2]) / g,
                  moment[0] / mg, moment[1] / mg, moment[2] / mg])
    r = [_sub(p, com) for p in feet]
    A = _wrench_map(r)
    U, q = _cost(A, b, weights)
    rows, lo = _friction_rows(normal, mu, fz_max_factor, k)
    alpha, stab_rows = _stability_rows(feet, com, normal, lam, body_x, r) if stability else (np.full(4, np.nan), [])
    x, used, C, low = _solve(U, q, rows, lo, stab_rows)
    return ForceSolution(forces=x.reshape(k, 3) * mg, stability_constrained=used, wrench_error=(A @ x - b) * mg,
                         cone_alpha_deg=alpha, constraint_matrix=C, constraint_lower=low * mg, n_friction_rows=len(rows))

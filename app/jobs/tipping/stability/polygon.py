"""Support polygon geometry: counter-clockwise ordering, least-squares ground plane,
centroid, and the static margins SSM and NESM that paper 002 compares FASM with."""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross for (..., 3) arrays without its axis shuffling (5-10x faster on small arrays,
    which is what a 1 ms control step is made of)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def tangent_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane normal to ``n`` (right-handed with n)."""
    n = n / np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = a - n * (a @ n)
    t1 /= np.linalg.norm(t1)
    return t1, cross3(n, t1)


def ccw_order(points: np.ndarray, up: np.ndarray = UP) -> np.ndarray:
    """Indices of the convex hull of ``points`` (k, 3), counter-clockwise seen from ``up``.
    Points strictly inside the hull are dropped: they are not support-polygon vertices."""
    pts = np.asarray(points, float)
    t1, t2 = tangent_basis(np.asarray(up, float))
    xy = np.stack([pts @ t1, pts @ t2], axis=1)
    return np.array(hull_ccw(xy.tolist()))


def hull_ccw(points: list) -> list[int]:
    """Indices of the convex hull, counter-clockwise seen from +z (monotone chain)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    if len(order) < 3:
        return order

    def turn(o, a, b):
        po, pa, pb = points[o], points[a], points[b]
        return (pa[0] - po[0]) * (pb[1] - po[1]) - (pa[1] - po[1]) * (pb[0] - po[0])

    lower: list[int] = []
    for i in order:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], i) <= 1e-12:
            lower.pop()
        lower.append(i)
    upper: list[int] = []
    for i in reversed(order):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], i) <= 1e-12:
            upper.pop()
        upper.append(i)
    return lower[:-1] + upper[:-1]


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares plane z = a x + b y + c through the feet (paper 002 Sec. 4.2, ref. 34).
    Returns (unit normal with positive z, a point on the plane: the feet's mean)."""
    p = np.asarray(points, float)
    A = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
    (a, b, c), *_ = np.linalg.lstsq(A, p[:, 2], rcond=None)
    n = np.array([-a, -b, 1.0])
    n /= np.linalg.norm(n)
    centre = p.mean(axis=0)
    centre[2] = a * centre[0] + b * centre[1] + c
    return n, centre


def project_to_plane(points: np.ndarray, normal: np.ndarray, origin: np.ndarray) -> np.ndarray:
    p = np.asarray(points, float)
    return p - np.outer((p - origin) @ normal, normal) if p.ndim == 2 else p - ((p - origin) @ normal) * normal


def polygon_centroid(points: np.ndarray, up: np.ndarray = UP) -> np.ndarray:
    """Area centroid G_s of the convex polygon (vertices CCW), by triangle fan (paper Eq. 21)."""
    p = np.asarray(points, float)
    if len(p) < 3:
        return p.mean(axis=0)
    a, b, c = p[0], p[1:-1], p[2:]
    areas = cross3(b - a, c - a) @ up * 0.5
    cents = (a + b + c) / 3.0
    if abs(areas.sum()) < 1e-12:
        return p.mean(axis=0)
    return (areas[:, None] * cents).sum(axis=0) / areas.sum()


def edge_frames(feet: np.ndarray, com: np.ndarray):
    """Per edge i (feet[i] -> feet[i+1], CCW): unit axis a_i and l_i, the perpendicular from
    the CoM to the axis line (P&R's l_i = (1 - a a^T)(p_{i+1} - p_c)). Shapes (..., k, 3)."""
    p = np.asarray(feet, float)
    nxt = np.roll(p, -1, axis=-2)
    a = nxt - p
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    d = nxt - np.asarray(com, float)[..., None, :]
    l = d - a * np.sum(a * d, axis=-1, keepdims=True)
    return a, l


def ssm(feet: np.ndarray, com: np.ndarray, up: np.ndarray = UP) -> tuple[float, np.ndarray]:
    """Static stability margin: signed distance, in the plane normal to gravity, from the CoM
    projection to each edge (positive inside). Returns (min, per-edge)."""
    p = np.asarray(feet, float)
    nxt = np.roll(p, -1, axis=0)
    e = nxt - p
    e -= np.outer(e @ up, up)
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    inward = cross3(np.broadcast_to(up, e.shape), e)
    r = np.asarray(com, float) - p
    r -= np.outer(r @ up, up)
    d = np.sum(r * inward, axis=1)
    return float(d.min()), d


def nesm(feet: np.ndarray, com: np.ndarray, up: np.ndarray = UP) -> tuple[float, np.ndarray]:
    """Normalised energy stability margin (Hirose): the height the CoM must rise, rotating
    about each edge, to stand above it. Per edge with r the perpendicular from the axis to the
    CoM: |r| |u_perp| - u . r, u_perp = u minus its axial part. Returns (min, per-edge), metres;
    edges the CoM is already past give negative values."""
    a, l = edge_frames(feet, com)
    r = -l
    u_perp = up - a * (a @ up)[:, None]
    h = np.linalg.norm(r, axis=1) * np.linalg.norm(u_perp, axis=1) - r @ up
    # The CoM is beyond the edge when it lies on the outer side: sign from the SSM test.
    _, s = ssm(feet, com, up)
    h = np.where(s < 0, -h, h)
    return float(h.min()), h

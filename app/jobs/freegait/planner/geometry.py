"""Stability and kinematic measures of Sec. 2.2-2.4 (paper 004), batched over leading axes.

All quantities live in the horizontal plane of the body frame at one instant: x forward,
y left, the COG at the origin (the paper: body level, COG at the geometric centre). The
body's motion is a ``Motion``: crab (speed V along the crab angle alpha), circling (the same
plus a yaw rate: the COG runs on a circle) or spinning (yaw rate only). Its "progress" s
is the COG's path length in metres (crab, circling) or the yaw angle in radians (spinning),
so distances such as R_1, R_e, L and the margin K keep the paper's meaning in every gait:
for circling, the paper's angular magnitudes (rho, psi, Eq. 25) times the COG's radius.

Tripod footholds are ordered (F, C, R): front, centre, rear leg of the tripod. The edges
of the support triangle are the rear edge C-R (the COG moves away from it), the front edge
F-C (it moves toward it) and the side edge R-F.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class Motion:
    speed: float  # V_BH, m/s along the crab direction
    alpha: float  # crab angle, rad (body x -> direction of motion)
    omega: float = 0.0  # yaw rate, rad/s (positive: turning left)

    @property
    def kind(self) -> str:
        if self.omega == 0.0:
            return "crab"
        return "spinning" if self.speed == 0.0 else "circling"

    @property
    def rate(self) -> float:
        """Progress per second: m/s of COG path, or rad/s when spinning."""
        return abs(self.omega) if self.kind == "spinning" else self.speed

    @property
    def direction(self) -> np.ndarray:
        return np.array([math.cos(self.alpha), math.sin(self.alpha)])

    @property
    def radius(self) -> float:
        return self.speed / abs(self.omega) if self.kind == "circling" else math.inf

    @property
    def centre(self) -> np.ndarray:
        """Centre of rotation (body frame) for circling; origin for spinning."""
        if self.kind == "spinning":
            return np.zeros(2)
        d = self.direction
        return np.array([-d[1], d[0]]) * self.speed / self.omega

    def heading(self, s) -> np.ndarray:
        """Yaw turned after progress s."""
        s = np.asarray(s, dtype=float)
        if self.kind == "crab":
            return np.zeros_like(s)
        if self.kind == "spinning":
            return math.copysign(1.0, self.omega) * s
        return s * self.omega / self.speed

    def cog(self, s) -> np.ndarray:
        """COG position (..., 2) after progress s, in the frame of the body now."""
        s = np.asarray(s, dtype=float)
        if self.kind == "crab":
            return s[..., None] * self.direction
        if self.kind == "spinning":
            return np.zeros(s.shape + (2,))
        c = self.centre
        th = self.heading(s)
        co, si = np.cos(th), np.sin(th)
        # c + R(th) (0 - c)
        return np.stack([c[0] - (co * c[0] - si * c[1]), c[1] - (si * c[0] + co * c[1])], axis=-1)

    def to_body(self, p: np.ndarray, s) -> np.ndarray:
        """Ground-fixed points p (..., 2), given in the body frame now, seen from the body
        after progress s (broadcast over s's shape)."""
        s = np.asarray(s, dtype=float)
        q = np.asarray(p, dtype=float) - self.cog(s)
        th = self.heading(s)
        co, si = np.cos(th), np.sin(th)
        return np.stack([co * q[..., 0] + si * q[..., 1], -si * q[..., 0] + co * q[..., 1]], axis=-1)

    def from_body(self, p: np.ndarray, s) -> np.ndarray:
        """Inverse of ``to_body``: body-frame points at progress s, in the frame of now."""
        s = np.asarray(s, dtype=float)
        p = np.asarray(p, dtype=float)
        th = self.heading(s)
        co, si = np.cos(th), np.sin(th)
        r = np.stack([co * p[..., 0] - si * p[..., 1], si * p[..., 0] + co * p[..., 1]], axis=-1)
        return r + self.cog(s)

    def local_direction(self, p: np.ndarray) -> np.ndarray:
        """Unit direction of the body's motion at body point p (..., 2): v + omega z x p."""
        p = np.asarray(p, dtype=float)
        v = self.speed * self.direction
        w = np.stack([v[0] - self.omega * p[..., 1], v[1] + self.omega * p[..., 0]], axis=-1)
        n = np.linalg.norm(w, axis=-1, keepdims=True)
        return np.where(n > 1e-12, w / np.maximum(n, 1e-12), np.array([1.0, 0.0]))


def line_terms(a: np.ndarray, b: np.ndarray, third: np.ndarray):
    """Unit normal n (..., 2) of line ab pointing toward ``third`` and offset c, so that the
    signed distance of x from the line is n.x + c (positive on the side of ``third``)."""
    e = b - a
    n = np.stack([-e[..., 1], e[..., 0]], axis=-1)
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-15)
    c = -np.sum(n * a, axis=-1)
    sgn = np.sign(np.sum(n * third, axis=-1) + c)
    sgn = np.where(sgn == 0, 1.0, sgn)
    return n * sgn[..., None], c * sgn


def triangle_margin(pf: np.ndarray, pc: np.ndarray, pr: np.ndarray, x: np.ndarray | None = None) -> np.ndarray:
    """Absolute static stability margin SM (Def. 1) of point x (default: the COG at the
    origin) in the triangle (pf, pc, pr): the smallest distance to a side, negative outside."""
    x = np.zeros(2) if x is None else np.asarray(x, dtype=float)
    out = None
    for a, b, t in ((pc, pr, pf), (pf, pc, pr), (pr, pf, pc)):
        n, c = line_terms(a, b, t)
        d = np.sum(n * x, axis=-1) + c
        out = d if out is None else np.minimum(out, d)
    return out


def polygon_margin(feet_xy: np.ndarray, x=(0.0, 0.0)) -> float:
    """SM of x in the convex hull of any number of footholds (records; not batched)."""
    pts = np.unique(np.round(np.asarray(feet_xy, dtype=float), 12), axis=0)
    if len(pts) < 3:
        return -math.inf
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    hull = np.array(lower[:-1] + upper[:-1])  # counter-clockwise
    if len(hull) < 3:
        return -math.inf
    x = np.asarray(x, dtype=float)
    e = np.roll(hull, -1, axis=0) - hull
    n = np.stack([-e[:, 1], e[:, 0]], axis=-1) / np.linalg.norm(e, axis=-1, keepdims=True)  # inward for ccw
    return float(np.min(np.sum(n * (x - hull), axis=-1)))


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def transfer_points_crab(pf, pc, pr, direction: np.ndarray, re):
    """Transfer starting point I and final point F on the straight path (Def. 3-5), closed form.

    Returns (t_I, L, SM_t): t_I is the COG progress at which I lies (I = t_I d), L = t_I the
    distance still to travel to I (Def. 4; negative once I has been passed), SM_t the
    transfer stability margin: the distance from I to the rear edge C-R, equal to that from
    F = I + R_e d to the front edge F-C (condition 1.3). Where the side edge R-F is closer
    (large crab angles) SM_t is the true smaller margin at I or F — the intent of Def. 5,
    "the absolute stability margin at the beginning and ending of a transfer phase".

    Each edge's terms depend on two of the three legs only, so they are computed on the
    smaller broadcast shapes; only the triangle's orientation and the final arithmetic run
    on all N^3 tripods (this is the hot path of the foothold search)."""
    d = np.asarray(direction, dtype=float)
    pf, pc, pr = (np.asarray(p, dtype=float) for p in (pf, pc, pr))

    def edge(a, b):
        # distance of t d from line ab, before the orientation sign: (A + B t) with
        # A = cross(e, -a) / |e|, B = cross(e, d) / |e|
        ex, ey = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
        ln = np.maximum(np.hypot(ex, ey), 1e-15)
        return _cross(ex, ey, -a[..., 0], -a[..., 1]) / ln, _cross(ex, ey, d[0], d[1]) / ln

    ar, br = edge(pc, pr)  # rear
    af, bf = edge(pf, pc)  # front
    a_s, b_s = edge(pr, pf)  # side
    # orientation of (F, C, R): +1 counter-clockwise; inside is where every signed distance is positive
    s = np.sign(_cross(pc[..., 0] - pf[..., 0], pc[..., 1] - pf[..., 1], pr[..., 0] - pf[..., 0], pr[..., 1] - pf[..., 1]))
    s = np.where(s == 0, 1.0, s)
    den = s * (br - bf)
    ok = den > 1e-12
    t = np.where(ok, (af + bf * re - ar) / np.where(ok, br - bf, 1.0), np.nan)
    smt = np.minimum(np.minimum(s * (ar + br * t), s * (a_s + b_s * t)), s * (a_s + b_s * (t + re)))
    smt = np.where(ok, smt, -np.inf)
    return t, t, smt


def transfer_points_path(pf, pc, pr, motion: Motion, re, s_max: float = 1.0, iters: int = 32):
    """Def. 3-5 on a circular COG path (circling): condition 1.3 solved by bisection on
    g(t) = d_rear(cog(t)) - d_front(cog(t + R_e)), increasing in t while the path crosses
    the triangle from its rear edge to its front edge."""
    nr, cr = line_terms(pc, pr, pf)
    nf, cf = line_terms(pf, pc, pr)
    ns, cs = line_terms(pr, pf, pc)
    shape = np.broadcast(pf[..., 0], pc[..., 0], pr[..., 0]).shape

    def dist(n, c, t):
        return np.sum(n * motion.cog(t), axis=-1) + c

    def g(t):
        return dist(nr, cr, t) - dist(nf, cf, t + re)

    lo = np.full(shape, -s_max)
    hi = np.full(shape, s_max)
    glo, ghi = g(lo), g(hi)
    ok = (glo <= 0) & (ghi >= 0)
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        gm = g(mid)
        up = gm < 0
        lo = np.where(up, mid, lo)
        hi = np.where(up, hi, mid)
    t = 0.5 * (lo + hi)
    smt = np.minimum(np.minimum(dist(nr, cr, t), dist(ns, cs, t)), dist(ns, cs, t + re))
    t = np.where(ok, t, np.nan)
    return t, t, np.where(ok, smt, -np.inf)


def transfer_points(pf, pc, pr, motion: Motion, re):
    if motion.kind == "crab":
        return transfer_points_crab(pf, pc, pr, motion.direction, re)
    return transfer_points_path(pf, pc, pr, motion, re)


def zeta_rect(p: np.ndarray, rect: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Distance a point p (..., 2) can move along unit u before leaving the rectangle
    rect (..., 4) = (xmin, xmax, ymin, ymax); negative when p is already outside (then
    minus the distance along -u back to the boundary is not defined: we return the most
    negative axis slack, which is what a margin needs)."""
    p = np.asarray(p, dtype=float)
    out = np.full(p.shape[:-1], np.inf)
    inside = (p[..., 0] >= rect[..., 0]) & (p[..., 0] <= rect[..., 1]) & (p[..., 1] >= rect[..., 2]) & (p[..., 1] <= rect[..., 3])
    for k in range(2):
        lo, hi = rect[..., 2 * k], rect[..., 2 * k + 1]
        uk = u[..., k]
        with np.errstate(divide="ignore", invalid="ignore"):
            dist = np.where(uk > 1e-12, (hi - p[..., k]) / uk, np.where(uk < -1e-12, (lo - p[..., k]) / uk, np.inf))
        out = np.minimum(out, dist)
    slack = np.minimum(np.minimum(p[..., 0] - rect[..., 0], rect[..., 1] - p[..., 0]),
                       np.minimum(p[..., 1] - rect[..., 2], rect[..., 3] - p[..., 1]))
    return np.where(inside, out, slack)


def zeta(p: np.ndarray, rect: np.ndarray, motion: Motion, s_max: float = 0.6, ds: float = 0.001) -> np.ndarray:
    """The paper's zeta (Def. 8) and psi (Eq. 25): how much body progress a ground-fixed
    point p (..., 2; body frame now) allows before it leaves its leg's workspace rect."""
    if motion.kind == "crab":
        return zeta_rect(p, rect, -motion.direction)
    p = np.asarray(p, dtype=float)
    s = np.arange(0.0, s_max + ds, ds)
    q = motion.to_body(p[..., None, :], s)  # (..., S, 2)
    r = rect[..., None, :]
    inside = (q[..., 0] >= r[..., 0]) & (q[..., 0] <= r[..., 1]) & (q[..., 1] >= r[..., 2]) & (q[..., 1] <= r[..., 3])
    first_out = np.where(inside.all(axis=-1), len(s) - 1, np.argmin(inside, axis=-1))
    z = s[np.maximum(first_out - 1, 0)]
    slack = zeta_rect(p, rect, np.array([1.0, 0.0]))
    return np.where(inside[..., 0], z, np.minimum(slack, 0.0))


def kinematic_margin(p: np.ndarray, rect: np.ndarray, motion: Motion, r1: float) -> np.ndarray:
    """Reduced kinematic margin K(P) = zeta - R_1 (Eq. 13; Eq. 25 when turning)."""
    return zeta(p, rect, motion) - r1

"""A slow per-candidate foothold search written from the definitions, independent of the
batched code: transfer points by bisection on the true stability margin, zeta by walking
the point out of the rectangle edge by edge, one tripod at a time."""

from __future__ import annotations

import math

import numpy as np


def _dist_line(p, a, b, third):
    ex, ey = b[0] - a[0], b[1] - a[1]
    ln = math.hypot(ex, ey)
    d = ((p[0] - a[0]) * ey - (p[1] - a[1]) * ex) / ln
    s = ((third[0] - a[0]) * ey - (third[1] - a[1]) * ex) / ln
    return d if s > 0 else -d  # positive on the side of ``third``


def sm(p, f, c, r):
    return min(_dist_line(p, c, r, f), _dist_line(p, f, c, r), _dist_line(p, r, f, c))


def transfer(f, c, r, d, re):
    """I by bisection on dist(I, CR) - dist(I + re d, FC); SM_t = min true SM at I and F."""
    def g(t):
        i = (t * d[0], t * d[1])
        e = ((t + re) * d[0], (t + re) * d[1])
        return _dist_line(i, c, r, f) - _dist_line(e, f, c, r)

    lo, hi = -2.0, 2.0
    if not (g(lo) <= 0 <= g(hi)):
        return None, -math.inf
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if g(mid) < 0:
            lo = mid
        else:
            hi = mid
    t = 0.5 * (lo + hi)
    i = (t * d[0], t * d[1])
    e = ((t + re) * d[0], (t + re) * d[1])
    return t, min(sm(i, f, c, r), sm(e, f, c, r))


def zeta(p, rect, d):
    """Distance p can move along -d inside rect (edge by edge); outside the rect, minus how
    far it is out (a foot outside its workspace has no margin)."""
    out = min(p[0] - rect[0], rect[1] - p[0], p[1] - rect[2], rect[3] - p[1])
    if out < 0:
        return out
    u = (-d[0], -d[1])
    best = math.inf
    for k, (lo, hi) in enumerate(((rect[0], rect[1]), (rect[2], rect[3]))):
        if u[k] > 1e-12:
            best = min(best, (hi - p[k]) / u[k])
        elif u[k] < -1e-12:
            best = min(best, (lo - p[k]) / u[k])
    return best


def search_reference(motion, params, cand, p1, rects, k_support, re, allowed=None):
    """Returns (best_index or None, best Ev, valid mask (N, N, N), per-condition counts)."""
    d = (math.cos(motion.alpha), math.sin(motion.alpha))
    v = motion.speed
    r1 = v * params.h1 / params.v1
    r3 = v * params.h3 / params.v3
    n = cand.shape[1]
    best, best_ev = None, -math.inf
    mask = np.zeros((n, n, n), dtype=bool)
    counts = [0] * 6
    for a in range(n):
        for b in range(n):
            for c in range(n):
                feet = [cand[0, a], cand[1, b], cand[2, c]]
                r2 = [v * abs(p1[l][0] - feet[l][0]) / params.v2 for l in range(3)]
                rt2 = max(r2)
                ok1 = True
                if allowed is not None:
                    for l in range(3):
                        gp = np.array([feet[l][0] + d[0] * rt2, feet[l][1] + d[1] * rt2])
                        ok1 = ok1 and bool(allowed(gp))
                ks = [zeta(feet[l], rects[l], d) - r1 for l in range(3)]
                kf = min(ks)
                t, smt = transfer(feet[0], feet[1], feet[2], d, re)
                lv = t if t is not None else -math.inf
                conds = [ok1, lv < k_support - rt2, kf > lv + re, lv > r3, smt > params.sm_min, r1 + rt2 + r3 < re]
                for i, cnd in enumerate(conds):
                    counts[i] += cnd
                if all(conds):
                    mask[a, b, c] = True
                    ev = kf + params.k_ev * smt
                    if ev > best_ev + 1e-12:
                        best, best_ev = (a, b, c), ev
    return best, best_ev, mask, counts

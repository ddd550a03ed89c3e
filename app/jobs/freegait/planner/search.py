"""Foothold planner (Sec. 3.3): N candidates per leg, all N^3 tripods checked against the
support conditions 1-6 (Eq. 18-23) and ranked by Ev = K + k_ev SM_t (Eq. 24), in one
batched pass; the spinning gait's turn support conditions 1-4 (Sec. 4.2) in the same shape.

Candidates (Fig. 7 is missing; documented in docs/freegait.md): in each leg's workspace a
grid aligned with the local direction of motion: ``n_along`` rows from
``candidate_back`` x the half stroke behind the workspace centre to the workspace's front
boundary, ``n_across`` = 3 columns over ``candidate_across`` of its width (1 column when
N < 6), the N - n_along x n_across left-over points on the centre line between the first
rows; clipped 1 mm inside the rectangle. Candidates are points F in the body frame at the
end of subphase 2.

Support condition 2 as printed compares L with K(F_F, F_C, F_R) - R_T2; its text says it
protects the legs *in support* ("the kinematic margin of the support tripod is reduced in
this amount ... the support legs are inside their workspaces up to the optimum instant"),
and K(F) > L + R_e (condition 3) would make the printed form redundant. We use the support
tripod's margin: L(F) < K(Q_F, Q_C, Q_R) - R_T2(F). Conditions 5 and 6 use the candidate
(F_F, F_C, F_R) (the copy's F_D, F_T is a typo; papers README).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from app.jobs.freegait.planner.geometry import Motion, kinematic_margin, transfer_points, triangle_margin
from app.jobs.freegait.planner.params import GaitParams, r1, r2, r3

# N^3 tripods are held in memory at once; this bounds N (and the spec checks it).
MAX_TRIPODS = 64_000  # N <= 40

CONDITIONS = ("c1_zones", "c2_support_margin", "c3_kinematic", "c4_touchdown", "c5_stability", "c6_displacement")
TURN_CONDITIONS = ("t1_zones", "t2_stability", "t3_kinematic", "t4_turn")


def candidate_grid(rect: np.ndarray, direction: np.ndarray, n: int, p: GaitParams) -> np.ndarray:
    """(n, 2) candidate footholds for one leg: rect (4,), direction (2,) unit."""
    cx, cy = 0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3])
    hx, hy = 0.5 * (rect[1] - rect[0]), 0.5 * (rect[3] - rect[2])
    d = np.asarray(direction, dtype=float)
    nrm = np.array([-d[1], d[0]])
    # Reach from the centre to the rectangle's boundary along d and across it.
    with np.errstate(divide="ignore"):
        a_max = min(hx / abs(d[0]) if abs(d[0]) > 1e-12 else np.inf, hy / abs(d[1]) if abs(d[1]) > 1e-12 else np.inf)
        c_max = min(hx / abs(nrm[0]) if abs(nrm[0]) > 1e-12 else np.inf, hy / abs(nrm[1]) if abs(nrm[1]) > 1e-12 else np.inf)
    n_across = 3 if n >= 6 else 1
    n_along = n // n_across
    along = np.linspace(-p.candidate_back * a_max, a_max, n_along)
    across = np.linspace(-p.candidate_across * c_max, p.candidate_across * c_max, n_across) if n_across > 1 else np.zeros(1)
    pts = [(a, c) for a in along for c in across]
    extra = n - n_along * n_across
    mids = 0.5 * (along[:-1] + along[1:]) if n_along > 1 else along
    pts += [(mids[k % len(mids)], 0.0) for k in range(extra)]
    ac = np.array(pts, dtype=float)
    xy = np.array([cx, cy]) + ac[:, :1] * d + ac[:, 1:] * nrm
    eps = 1e-3
    xy[:, 0] = np.clip(xy[:, 0], rect[0] + eps, rect[1] - eps)
    xy[:, 1] = np.clip(xy[:, 1], rect[2] + eps, rect[3] - eps)
    return xy


@dataclasses.dataclass
class SearchInput:
    motion: Motion
    params: GaitParams
    candidates: np.ndarray  # (3, N, 2) body frame at the end of subphase 2, legs (F, C, R)
    p1: np.ndarray  # (3, 2) the lifted feet (P_1) now
    rects: np.ndarray  # (3, 4) workspaces of the transferring legs
    k_support: float  # K of the tripod in support, now
    re: float  # R_e
    allowed: Callable[[np.ndarray], np.ndarray] | None = None  # (..., 2) body-frame-now points -> bool


@dataclasses.dataclass
class SearchResult:
    found: bool
    index: tuple[int, int, int] | None
    footholds: np.ndarray | None  # (3, 2) F of the chosen tripod
    ground_points: np.ndarray | None  # (3, 2) F' (Eq. 18), body frame now
    ev: float
    k: float
    sm_t: float
    l: float
    r_t2: float
    counts: dict[str, int]  # candidates passing each condition alone, and "valid"


def _shifted_allowed(inp: SearchInput, r2v: np.ndarray):
    """allowed[l, i, m]: candidate i of leg l lands outside every forbidden area when the
    body moves by the m-th of the 3N subphase-2 progresses (Eq. 18) before it lands."""
    shifts = r2v.reshape(-1)  # (3N,)
    pts = inp.motion.from_body(inp.candidates[:, :, None, :], shifts[None, None, :])  # (3, N, 3N, 2)
    if inp.allowed is None:
        return np.ones(pts.shape[:-1], dtype=bool), pts
    return np.asarray(inp.allowed(pts), dtype=bool), pts


def evaluate(inp: SearchInput) -> dict:
    """Every condition, Ev and the derived magnitudes for all N^3 tripods (arrays (N, N, N)).
    Crab and circling: support conditions 1-6; spinning: turn support conditions 1-4 with
    Ev = K_G + k_ev SM (the copy gives no turning criterion; we keep Eq. 24's form with the
    new tripod's own SM)."""
    m, p = inp.motion, inp.params
    cand = inp.candidates
    n = cand.shape[1]
    rr1, rr3 = r1(m, p), r3(m, p)
    r2v = r2(m, p, inp.p1[:, None, 0], cand[:, :, 0])  # (3, N)
    ok_zone, pts = _shifted_allowed(inp, r2v)
    kc = kinematic_margin(cand, inp.rects[:, None, :], m, rr1)  # (3, N)
    i, j, k = np.ix_(np.arange(n), np.arange(n), np.arange(n))
    stack = np.stack(np.broadcast_arrays(r2v[0][:, None, None], r2v[1][None, :, None], r2v[2][None, None, :]))
    leg = np.argmax(stack, axis=0)  # which leg sets R_T2 (Eq. 11; the first on ties)
    rt2 = np.take_along_axis(stack, leg[None], axis=0)[0]
    mi = leg * n + np.select([leg == 0, leg == 1], [i, j], k)  # that progress among the 3N
    zones = ok_zone[0][i, mi] & ok_zone[1][j, mi] & ok_zone[2][k, mi]
    kf = np.minimum(np.minimum(kc[0][:, None, None], kc[1][None, :, None]), kc[2][None, None, :])
    pf, pc, pr = cand[0][:, None, None, :], cand[1][None, :, None, :], cand[2][None, None, :, :]
    c6 = np.broadcast_to(rr1 + rt2 + rr3 < inp.re, zones.shape)
    if m.kind == "spinning":
        sm = triangle_margin(pf, pc, pr)
        conds = {"t1_zones": zones, "t2_stability": sm > p.sm_min, "t3_kinematic": kf > inp.re, "t4_turn": c6}
        lv = np.zeros_like(sm)
    else:
        _, lv, sm = transfer_points(pf, pc, pr, m, inp.re)
        lv = np.where(np.isnan(lv), -np.inf, lv)
        conds = {"c1_zones": zones, "c2_support_margin": lv < inp.k_support - rt2, "c3_kinematic": kf > lv + inp.re,
                 "c4_touchdown": lv > rr3, "c5_stability": sm > p.sm_min, "c6_displacement": c6}
    valid = np.logical_and.reduce(list(conds.values()))
    return {"conds": conds, "valid": valid, "ev": kf + p.k_ev * sm, "k": kf, "sm_t": sm, "l": lv, "r_t2": rt2,
            "mi": mi, "pts": pts}


def search(inp: SearchInput, rng: np.random.Generator | None = None) -> SearchResult:
    """The best valid tripod by Ev (Eq. 24); with ``rng``, a uniformly random valid tripod
    instead (the control that measures what Ev earns)."""
    e = evaluate(inp)
    valid = e["valid"]
    counts = {name: int(c.sum()) for name, c in e["conds"].items()}
    counts["valid"] = int(valid.sum())
    if not valid.any():
        return SearchResult(False, None, None, None, -np.inf, np.nan, np.nan, np.nan, np.nan, counts)
    if rng is None:
        flat = int(np.argmax(np.where(valid, e["ev"], -np.inf)))
    else:
        flat = int(rng.choice(np.flatnonzero(valid)))
    a, b, c = (int(v) for v in np.unravel_index(flat, valid.shape))
    cand, pts = inp.candidates, e["pts"]
    ml = int(e["mi"][a, b, c])
    gp = np.stack([pts[0, a, ml], pts[1, b, ml], pts[2, c, ml]])
    return SearchResult(True, (a, b, c), np.stack([cand[0, a], cand[1, b], cand[2, c]]), gp,
                        float(e["ev"][a, b, c]), float(e["k"][a, b, c]), float(e["sm_t"][a, b, c]),
                        float(e["l"][a, b, c]), float(e["r_t2"][a, b, c]), counts)

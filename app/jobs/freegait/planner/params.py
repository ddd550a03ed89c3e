"""Gait parameters (Sec. 5) and the transfer-phase distances of Eq. 7-12.

H1, H2, H3 are given in the copy as -0.13, -0.11, -0.20 m (heights in the body frame,
below the body). Eq. 7 and 10 use H1 and H3 as the distances the foot rises in subphase 1
and may descend in subphase 3, so we use their magnitudes. No equation of the copy uses
H2; we use it as the foot's least clearance over the estimated ground along subphase 2
(the lifted foot never dips below it on its way to P_2, which sits H3/2 over the estimate).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.freegait.planner.geometry import Motion


@dataclasses.dataclass(frozen=True)
class GaitParams:
    sm_min: float = 0.05
    k_ev: float = 0.04
    n_candidates: int = 15
    h1: float = 0.13
    h2: float = 0.11
    h3: float = 0.20
    v1: float = 0.10
    v2: float = 0.30
    v3: float = 0.10
    re_margin: float = 1.15  # R_e = this x R at the nominal step (Sec. 3.1: "a typical time")
    candidate_across: float = 0.75  # candidates span this share of the workspace width
    candidate_back: float = 0.25  # ... and from this share of the half stroke behind the centre


def r1(motion: Motion, p: GaitParams) -> float:
    """Eq. 7: body progress during subphase 1."""
    return motion.rate * p.h1 / p.v1


def r2(motion: Motion, p: GaitParams, p1x: np.ndarray, fx: np.ndarray) -> np.ndarray:
    """Eq. 9: body progress during subphase 2 of a foot going from P_1 to F. The copy's
    (P_1x - F_x) is the foot's travel along the body x axis; its sign depends on the
    figure's axes (missing), so we take its magnitude: a duration cannot be negative."""
    return motion.rate * np.abs(np.asarray(p1x) - np.asarray(fx)) / p.v2


def r3(motion: Motion, p: GaitParams) -> float:
    """Eq. 10: body progress during a full subphase 3 (no contact before H3)."""
    return motion.rate * p.h3 / p.v3


def transfer_times(p: GaitParams, p1x: np.ndarray, fx: np.ndarray) -> tuple[float, float, float]:
    """Durations of subphases 1, 2 (tripod, synchronised: the slowest leg) and a full 3."""
    t2 = float(np.max(np.abs(np.asarray(p1x) - np.asarray(fx)))) / p.v2
    return p.h1 / p.v1, t2, p.h3 / p.v3


def nominal_re(motion: Motion, p: GaitParams, stroke: float) -> float:
    """R_e from a typical transfer (Sec. 3.1): subphases 1 and 3 in full and a subphase 2
    over one stroke, times a margin; progress units of ``motion``."""
    return p.re_margin * (r1(motion, p) + motion.rate * stroke / p.v2 + r3(motion, p))

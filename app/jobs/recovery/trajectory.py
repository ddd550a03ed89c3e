"""Leg-tip trajectories of paper 000, Eq. 3, batched over candidates.

Eq. 3 indexes one gait period by samples k = 1..N_g, swing first. With the phase
phi = (k - 1) / N_g in [0, 1) the same curves read, for a leg whose swing starts at
phase offset s / sigma:

    swing   (u = sigma*phi in [0, 1)):           y = y0 - L_sl/2 cos(pi u)
                                                 z = z0 - H0 + L_sh/2 (1 - cos(2 pi u))
    support (v = (phi - 1/sigma)/(1 - 1/sigma)): y = y0 + L_sl/2 cos(pi v)
                                                 z = z0 - H0 + L_sd/2 (1 - cos(2 pi v))

which is exactly Eq. 3 at every sample but does not need N_g divisible by sigma.
Positions are in a leg's hip frame: origin at the coxa axis, x outward, y forward, z up.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.recovery.sequences import GaitSequence
from app.robots.catalog import RobotEntry


def param_names(legs: list[int]) -> list[str]:
    """Eq. 4 for the functional legs: [y0_i..., x0_i..., L_sl, L_sh]."""
    return [f"y0_leg{l}" for l in legs] + [f"x0_leg{l}" for l in legs] + ["step_length", "step_height"]


def leg_phase(t: np.ndarray, period: float, seq: GaitSequence, legs: list[int]) -> np.ndarray:
    """Phase (T, nlegs) in [0, 1) of each leg's own cycle, 0 = start of its swing."""
    offsets = np.array([seq.swing_phase[l] / seq.sigma for l in legs])
    return np.mod(t[:, None] / period - offsets[None, :], 1.0)


def tip_shapes(t: np.ndarray, period: float, seq: GaitSequence, legs: list[int]) -> tuple[np.ndarray, ...]:
    """Eq. 3's shapes (T, nlegs) each: the stride y_rel in [-1, 1] (the tip is at y0 +
    L_sl/2 y_rel: back at -1 when its swing starts, forward at +1 when its support starts),
    the swing lift z_rel and the support dip z_sup, both in [0, 2]."""
    sigma = seq.sigma
    phi = leg_phase(t, period, seq, legs)
    swing = phi < 1.0 / sigma
    u = phi * sigma
    v = (phi - 1.0 / sigma) / (1.0 - 1.0 / sigma)
    y_rel = np.where(swing, -np.cos(np.pi * u), np.cos(np.pi * v))
    z_rel = np.where(swing, 1.0 - np.cos(2 * np.pi * u), 0.0)
    z_sup = np.where(swing, 0.0, 1.0 - np.cos(2 * np.pi * v))
    return y_rel, z_rel, z_sup


def tip_positions(
    params: np.ndarray,
    legs: list[int],
    seq: GaitSequence,
    t: np.ndarray,
    period: float,
    stance_height: float,
    step_depth: float = 0.0,
    z0: float = 0.0,
) -> np.ndarray:
    """Tip targets (P, T, nlegs, 3) for candidates params (P, 2*nlegs + 2)."""
    params = np.atleast_2d(np.asarray(params, dtype=float))
    n = len(legs)
    if params.shape[1] != 2 * n + 2:
        raise ValueError(f"params has {params.shape[1]} columns, expected {2 * n + 2} for legs {legs}")
    y0 = params[:, None, :n]  # (P, 1, n)
    x0 = params[:, None, n : 2 * n]
    step_len = params[:, None, None, 2 * n]  # (P, 1, 1)
    step_h = params[:, None, None, 2 * n + 1]

    y_rel, z_rel, z_sup = (a[None] for a in tip_shapes(t, period, seq, legs))  # (1, T, n) each

    out = np.empty((params.shape[0], t.shape[0], n, 3))
    out[..., 0] = x0
    out[..., 1] = y0 + 0.5 * step_len * y_rel
    out[..., 2] = z0 - stance_height + 0.5 * step_h * z_rel + 0.5 * step_depth * z_sup
    return out


def swing_mask(t: np.ndarray, period: float, seq: GaitSequence, legs: list[int]) -> np.ndarray:
    """(T, nlegs) True while a leg swings."""
    return leg_phase(t, period, seq, legs) < 1.0 / seq.sigma



@dataclasses.dataclass(frozen=True)
class SearchBox:
    """X_min / X_max of paper 000, Sec. IV-B (m): the lateral offset y0 per leg, the reach
    x0, the step length and the step height. The spec's ``bounds`` section overrides any."""

    y0: dict[int, tuple[float, float]]
    x0: tuple[float, float]
    step_length: tuple[float, float]
    step_height: tuple[float, float]

    def describe(self) -> dict:
        return {"y0_bounds_m": {str(k): list(v) for k, v in self.y0.items()}, "x0_bounds_m": list(self.x0),
                "step_length_bounds_m": list(self.step_length), "step_height_bounds_m": list(self.step_height)}


# The paper's box for its robot, by catalog name (app/robots/catalog.py), with y0 paired
# front (1, 2), middle (3, 4), rear (5, 6), centred on the robot's nominal stance
# (tests/jobs/recovery/test_recovery.py checks it). Any other robot, built-in or uploaded,
# gets ``stance_box``.
BUILT_IN: dict[str, SearchBox] = {
    "jethexa": SearchBox(
        y0={1: (-0.01, 0.05), 2: (-0.01, 0.05), 3: (-0.03, 0.03), 4: (-0.03, 0.03), 5: (-0.05, 0.01),
            6: (-0.05, 0.01)},
        x0=(0.09, 0.13), step_length=(0.02, 0.05), step_height=(0.02, 0.05)),
}


def stance_box(x0: float, y0: dict[int, float], stance_height: float) -> SearchBox:
    """A box scaled by the robot's stance height H around its nominal stance: y0 +- 0.3 H,
    x0 +- 0.2 H, steps 0.2-0.5 H long and high."""
    H = stance_height
    return SearchBox(y0={n: (y - 0.3 * H, y + 0.3 * H) for n, y in y0.items()}, x0=(x0 - 0.2 * H, x0 + 0.2 * H),
                     step_length=(0.2 * H, 0.5 * H), step_height=(0.2 * H, 0.5 * H))


def search_box(robot) -> SearchBox:
    """The box of a built-in robot (a ``RobotEntry``: the paper's where it has one, else its
    stance's) or of an uploaded one (its ``box``, from its stance too)."""
    if not isinstance(robot, RobotEntry):
        return robot.box
    return BUILT_IN.get(robot.name) or stance_box(robot.nominal_x0(), {l: robot.nominal_y0(l) for l in robot.legs},
                                                  robot.stance_height)


def bounds_of(b, robot, legs: list[int], relaxed: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """X_min / X_max of ``legs`` from the spec's bounds ``b`` (they win) and the robot's box
    (``search_box``: a built-in or an uploaded robot); the y0 bounds of the ``relaxed`` legs
    widened."""
    box = search_box(robot)
    y_lo, y_hi = [], []
    for leg in legs:
        lo, hi = b.y0_m.get(str(leg), box.y0[leg])
        if leg in relaxed:
            w = (hi - lo) * b.neighbour_relaxation
            lo, hi = lo - w, hi + w
        y_lo.append(lo)
        y_hi.append(hi)
    x_lo, x_hi = b.x0_m or box.x0
    sl = b.step_length_m or box.step_length
    sh = b.step_height_m or box.step_height
    return (np.array(y_lo + [x_lo] * len(legs) + [sl[0], sh[0]]),
            np.array(y_hi + [x_hi] * len(legs) + [sl[1], sh[1]]))

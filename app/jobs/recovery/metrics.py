"""Body metrics and the recovery objective (paper 000, Eq. 5), batched over candidates.

Angles are ZYX Euler angles of the body (yaw psi about z, then about y, then about x).
Forward is +Y, so, as the paper writes, roll is the rotation about y and pitch the
rotation about x.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from app.jobs.evidence import Target

FALL_FITNESS = -1.0
UNITS = ("m_rad", "cm_deg")
METRIC_KEYS = ("x_f_m", "y_f_m", "yaw_f_deg", "roll_amp_deg", "pitch_amp_deg", "tilt_max_deg", "under_3_feet_frac",
               "fell")


def euler_zyx(quat: np.ndarray) -> np.ndarray:
    """(..., 4) wxyz -> (..., 3) [yaw_z, rot_y, rot_x] in radians."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    rot_y = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    rot_x = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    return np.stack([yaw, rot_y, rot_x], axis=-1)


def fallen(torso_z: np.ndarray, quat: np.ndarray, min_height: float, max_tilt_rad: float,
           ground_contacts: np.ndarray | None = None) -> np.ndarray:
    """(P, T) -> (P,) True if at any step a body that must not touch the ground did
    (``ground_contacts`` (P, T, n): contact-sensor counts of the chassis and upper legs),
    the body sagged below min_height or tilted past max_tilt (body z vs world z)."""
    w, x, y, _ = np.moveaxis(quat, -1, 0)
    up_z = 1 - 2 * (x * x + y * y)
    bad = (torso_z < min_height) | (up_z < np.cos(max_tilt_rad))
    if ground_contacts is not None:
        bad |= np.any(ground_contacts > 0, axis=-1)
    return np.any(bad, axis=1)


def body_metrics(com: np.ndarray, quat: np.ndarray, fell: np.ndarray,
                 feet: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Metrics of Eq. 5 from the walking window: com (P, T, 3), quat (P, T, 4).

    x_f, y_f: displacement of the centre of mass from the window's start; yaw_f: change of
    (unwrapped) yaw; amplitudes: half the peak-to-peak excursion over the window; tilt_max:
    the largest angle between body z and world z; with ``feet`` (contact counts (P, T, n)),
    the share of the window spent on fewer than three feet.
    """
    ang = euler_zyx(quat)
    yaw = np.unwrap(ang[..., 0], axis=1)
    d = com[:, -1, :2] - com[:, 0, :2]
    half_ptp = 0.5 * (ang.max(axis=1) - ang.min(axis=1))
    w, qx, qy, _ = np.moveaxis(quat, -1, 0)
    up_z = np.clip(1 - 2 * (qx * qx + qy * qy), -1.0, 1.0)
    out = {
        "x_f_m": d[:, 0],
        "y_f_m": d[:, 1],
        "yaw_f_deg": np.degrees(yaw[:, -1] - yaw[:, 0]),
        "roll_amp_deg": np.degrees(half_ptp[:, 1]),
        "pitch_amp_deg": np.degrees(half_ptp[:, 2]),
        "tilt_max_deg": np.degrees(np.arccos(up_z.min(axis=1))),
    }
    if feet is not None:  # (P, T, nfeet) contact counts: share of the walk on fewer than three feet
        out["under_3_feet_frac"] = np.mean(np.sum(feet > 0, axis=-1) < 3, axis=1)
    out["fell"] = np.asarray(fell, dtype=bool)
    return out


def objective_terms(metrics: dict[str, np.ndarray], weights, units: str = "m_rad") -> dict[str, np.ndarray]:
    """Named, weighted terms of Eq. 5.

    The paper does not say in which units Eq. 5 is evaluated. ``units`` picks metres and
    radians ("m_rad") or centimetres and degrees ("cm_deg", the units of its Table II).

    The paper's numerator is w1 * y_f^2, which rewards walking backwards as much as
    forwards; its stated intent is forward progression, so we keep the sign:
    w1 * y_f * |y_f|. A fallen candidate gets FALL_FITNESS, below any walker's F.
    """
    w1, w2, w3, w4, w5 = (float(w) for w in weights)
    if units not in UNITS:
        raise ValueError(f"units must be one of {UNITS}, got {units!r}")
    pos = 100.0 if units == "cm_deg" else 1.0
    ang = 1.0 if units == "cm_deg" else np.pi / 180.0
    y = pos * metrics["y_f_m"]
    return {
        "forward": w1 * y * np.abs(y),
        "drift": w2 * (pos * metrics["x_f_m"]) ** 2,
        "yaw": w3 * (ang * metrics["yaw_f_deg"]) ** 2,
        "roll": w4 * (ang * metrics["roll_amp_deg"]) ** 2,
        "pitch": w5 * (ang * metrics["pitch_amp_deg"]) ** 2,
    }


def fitness(metrics: dict[str, np.ndarray], weights, units: str = "m_rad") -> np.ndarray:
    t = objective_terms(metrics, weights, units)
    f = t["forward"] / (1.0 + t["drift"] + t["yaw"] + t["roll"] + t["pitch"])
    # Walkers are clipped just above the fall value so that a fall always ranks last.
    return np.where(metrics["fell"], FALL_FITNESS, np.maximum(f, FALL_FITNESS + 1e-3))


def fitness_bound(y_reach_m: np.ndarray, roll_amp_deg: np.ndarray, pitch_amp_deg: np.ndarray, weights,
                  units: str = "m_rad") -> np.ndarray:
    """An upper bound of Eq. 5's F for walks that cannot end further forward than
    ``y_reach_m`` and whose roll and pitch amplitudes are at least the given ones: the
    drift and yaw terms are at least 0, so the denominator is at least 1 plus the roll and
    pitch terms; a walk that cannot end forward scores below 0 (a fall -1)."""
    zero = np.zeros_like(np.asarray(y_reach_m, dtype=float))
    t = objective_terms({"y_f_m": y_reach_m, "x_f_m": zero, "yaw_f_deg": zero, "roll_amp_deg": roll_amp_deg,
                         "pitch_amp_deg": pitch_amp_deg}, weights, units)
    return np.maximum(t["forward"] / (1.0 + t["roll"] + t["pitch"]), 0.0)


# The recovery target (issue 12): what "walks straight again" means over a 10 s walk. The
# one TARGET below is what the summary, the page, the CLI and the studies all apply.
LIMITS = {"y_min_m": 0.5, "x_abs_max_m": 0.05, "yaw_abs_max_deg": 10.0}


def target_checks(metrics: Mapping[str, Any]) -> dict[str, bool]:
    """Each condition of the target on one candidate's metrics (scalars), so a page can
    mark each; the target is met when all hold."""
    return {"forward": float(metrics["y_f_m"]) >= LIMITS["y_min_m"],
            "lateral": abs(float(metrics["x_f_m"])) <= LIMITS["x_abs_max_m"],
            "yaw": abs(float(metrics["yaw_f_deg"])) <= LIMITS["yaw_abs_max_deg"],
            "upright": not bool(metrics["fell"])}


def meets_target(metrics: Mapping[str, Any]) -> bool:
    return all(target_checks(metrics).values())


TARGET = Target("forward >= 50 cm, |lateral| <= 5 cm, |yaw| <= 10 deg at the end of the walk, and no fall",
                meets_target)

"""Closed-form inverse kinematics of a 3-DoF coxa-femur-tibia leg (paper 000, Eq. 11).

Coordinates are in the leg frame (origin at the coxa axis, x outward, z up). The typeset
Eq. 11 uses arcsin for q2 and q3: arcsin(D) - pi/2 equals -arccos(D) (knee bent down),
and arcsin(z/A) - gamma equals atan2(z, r) - atan2(L3 s3, L2 + L3 c3) only while
L2 + L3 cos(q3) > 0 and |q2 + gamma| < pi/2 (the typeset arctan loses the quadrant when
the knee folds past arccos(-L2/L3)). We use the atan2 form, exact on the whole branch
with the foot outside the femur joint; tests check both against MuJoCo forward
kinematics and show where the typeset one breaks.
"""

from __future__ import annotations

import numpy as np


def leg_ik(p: np.ndarray, lengths: tuple[float, float, float]) -> np.ndarray:
    """Joint angles (..., 3) for tip positions p (..., 3) in the leg frame.

    Points outside the reach are clamped to the boundary (fully stretched or folded
    leg), so a candidate that asks for too much still gets a defined command.
    """
    L1, L2, L3 = lengths
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    q1 = np.arctan2(y, x)
    r = np.cos(q1) * x + np.sin(q1) * y - L1
    D = (r * r + z * z - L2 * L2 - L3 * L3) / (2.0 * L2 * L3)
    D = np.clip(D, -1.0, 1.0)
    q3 = -np.arccos(D)
    s3, c3 = np.sin(q3), np.cos(q3)
    q2 = np.arctan2(z, r) - np.arctan2(L3 * s3, L3 * c3 + L2)
    return np.stack([q1, q2, q3], axis=-1)


def leg_ik_paper(p: np.ndarray, lengths: tuple[float, float, float]) -> np.ndarray:
    """Eq. 11 as typeset (arcsin form); kept to prove it agrees with ``leg_ik``."""
    L1, L2, L3 = lengths
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    q1 = np.arctan(y / x)
    c1, s1 = np.cos(q1), np.sin(q1)
    q3 = np.arcsin(((c1 * x + s1 * y - L1) ** 2 + z**2 - L3**2 - L2**2) / (2 * L2 * L3)) - np.pi / 2
    s3, c3 = np.sin(q3), np.cos(q3)
    gamma = np.arctan(L3 * s3 / (L3 * c3 + L2))
    q2 = np.arcsin(z / np.sqrt((L3 * c3 + L2) ** 2 + (L3 * s3) ** 2)) - gamma
    return np.stack([q1, q2, q3], axis=-1)


def leg_fk(q: np.ndarray, lengths: tuple[float, float, float]) -> np.ndarray:
    """Tip position (..., 3) in the leg frame for joint angles q (..., 3)."""
    L1, L2, L3 = lengths
    q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2]
    r = L1 + L2 * np.cos(q2) + L3 * np.cos(q2 + q3)
    z = L2 * np.sin(q2) + L3 * np.sin(q2 + q3)
    return np.stack([r * np.cos(q1), r * np.sin(q1), z], axis=-1)

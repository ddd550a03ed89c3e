"""Leg kinematics of the heavy-duty hexapod (paper 002, Eq. 1-2): in the mirrored coxa
frame of a leg (y outward, z up) the foot is the point (L1, -d) turned by the swing angle
theta about x, with d = K_z J_z + L2 the leg length and an independent horizontal travel
x = K_x J_x. Everything here is in the body frame. The robot's builder and the stability
code (footholds, reachable space) both use it, so it lives with the robot.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class LegWorkspace:
    leg: int
    hip: tuple[float, float, float]  # B_i, origin of the coxa frame in the body frame
    side: int  # +1 left (legs 1-3, L1 > 0 in the paper), -1 right
    l1: float  # leg-plane offset L1 (magnitude)
    d_range: tuple[float, float]  # leg length K_z J_z + L2
    theta_range: tuple[float, float]  # swing joint J_theta, radians, positive = outward
    x_range: tuple[float, float]  # horizontal travel K_x J_x

    @property
    def l_max(self) -> float:
        return float(np.hypot(self.l1, self.d_range[1]))


def leg_fk(ws: LegWorkspace, x: np.ndarray, d: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Eq. 1 in the body frame, batched over the joint arrays."""
    x, d, theta = np.broadcast_arrays(np.asarray(x, float), np.asarray(d, float), np.asarray(theta, float))
    py = ws.l1 * np.cos(theta) + d * np.sin(theta)
    pz = ws.l1 * np.sin(theta) - d * np.cos(theta)
    return np.asarray(ws.hip) + np.stack([x, ws.side * py, pz], axis=-1)


def leg_ik(ws: LegWorkspace, p: np.ndarray) -> np.ndarray:
    """Eq. 2 written without the copy's typos: (x, d, theta) for body-frame foot points
    (..., 3). Exact inverse of ``leg_fk`` wherever d > 0."""
    q = np.asarray(p, float) - np.asarray(ws.hip)
    qy, qz = ws.side * q[..., 1], q[..., 2]
    d = np.sqrt(np.maximum(qy * qy + qz * qz - ws.l1 ** 2, 0.0))
    theta = np.arctan2(qz, qy) - np.arctan2(-d, ws.l1)
    theta = (theta + np.pi) % (2 * np.pi) - np.pi
    return np.stack([q[..., 0], d, theta], axis=-1)


def reachable(ws: LegWorkspace, x: np.ndarray, d: np.ndarray, theta: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    (x0, x1), (d0, d1), (t0, t1) = ws.x_range, ws.d_range, ws.theta_range
    return ((x >= x0 - tol) & (x <= x1 + tol) & (d >= d0 - tol) & (d <= d1 + tol)
            & (theta >= t0 - tol) & (theta <= t1 + tol))

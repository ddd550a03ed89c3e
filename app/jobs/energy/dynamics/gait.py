"""Gait timing and the prescribed foot paths of paper 003 (Sec. I-A, I-B step 4).

A gait is the period T, each leg's touchdown time t_i in [0, T) and duty factor beta_i
(contact lasts beta_i T, wrapping over the period's end). Feet are given in the world:
in stance a foot rests on its foothold; in swing it travels from lift-off to the next
foothold along a quintic Bezier curve that reaches ``swing_height`` (Fig. 2, z_sp). The
footholds are those of the "dummy" body moving at constant speed V and height h: each
foothold lies under its hip at mid-stance, so the stance foot sweeps symmetrically under
the hip. Every later stage re-solves the legs by IK against these same world paths, so the
legs stay "compatible with the body" (Sec. II-B) whatever the body does.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.robots.quadruped import LEGS, QuadrupedGeometry

# Quintic Bezier control points (u in [0, 1]): x with zero speed and acceleration at both
# ends (the foot leaves and lands at rest), z up to the apex and back with zero vertical speed.
_BX = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
_BZ = np.array([0.0, 0.0, 1.0, 1.0, 0.0, 0.0]) / 0.625  # apex (u = 1/2) of the z curve = 1


def _bezier(ctrl: np.ndarray, u: np.ndarray, deriv: int = 0) -> np.ndarray:
    """Value or derivative (d/du, order 0-2) of a quintic Bezier with scalar control points."""
    c = ctrl.astype(float)
    n = 5
    for _ in range(deriv):
        c = n * np.diff(c)
        n -= 1
    k = np.arange(n + 1)
    binom = np.array([math.comb(n, j) for j in k], dtype=float)
    u = np.asarray(u, dtype=float)[..., None]
    return (binom * u**k * (1 - u) ** (n - k)) @ c


@dataclasses.dataclass(frozen=True)
class Gait:
    period: float
    touchdown: tuple[float, float, float, float]  # FR, HR, FL, HL (s)
    duty: tuple[float, float, float, float]

    def phase(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(len(t), 4): time since touchdown modulo T, and stance mask (0 < tau < beta T)."""
        t = np.asarray(t, dtype=float)[:, None]
        tau = np.mod(t - np.asarray(self.touchdown), self.period)
        beta = np.asarray(self.duty)
        stance = (tau > 0.0) & (tau < beta * self.period) | (beta >= 1.0)
        return tau, stance


def trot(period: float, duty: float = 0.5) -> Gait:
    """Paper 003's trot: FR with HL, HR with FL, half a period apart."""
    return Gait(period=period, touchdown=(0.0, period / 2, period / 2, 0.0), duty=(duty,) * 4)


@dataclasses.dataclass(frozen=True)
class Task:
    speed: float = 1.0  # V (m/s)
    height: float = 0.5  # h: mean trunk CoM height above the foot tips (m)
    swing_height: float = 0.25  # z_sp (m)
    friction: float = 0.6  # mu_s


def foot_offsets(geom: QuadrupedGeometry) -> np.ndarray:
    """(4, 2): nominal foot x, y in the body frame (under the hip, beside it by l_hip)."""
    out = []
    for leg in LEGS:
        hip = geom.hip(leg)
        out.append([hip[0], hip[1] + geom.side(leg) * geom.links[0]])
    return np.asarray(out)


def feet_world(gait: Gait, task: Task, geom: QuadrupedGeometry, t: np.ndarray, deriv: int = 0) -> np.ndarray:
    """(len(t), 4, 3): world foot positions (or their time derivative of order ``deriv``)."""
    t = np.asarray(t, dtype=float)
    T, V = gait.period, task.speed
    off = foot_offsets(geom)
    out = np.zeros((t.size, 4, 3))
    for i in range(4):
        ti, beta = gait.touchdown[i], gait.duty[i]
        # Index of the stance phase that started last (touchdown at ti + n T).
        n = np.floor((t - ti) / T)
        tau = t - ti - n * T
        t_td = ti + n * T
        hold_x = V * (t_td + 0.5 * beta * T) + off[i, 0]
        x = np.array(hold_x)
        z = np.zeros_like(t)
        xd = np.zeros_like(t)
        zd = np.zeros_like(t)
        if beta < 1.0:
            sw = tau >= beta * T
            d_sw = (1.0 - beta) * T
            u = np.clip((tau - beta * T) / d_sw, 0.0, 1.0)
            if deriv == 0:
                x = np.where(sw, hold_x + V * T * _bezier(_BX, u), hold_x)
                z = np.where(sw, task.swing_height * _bezier(_BZ, u), 0.0)
            else:
                xd = np.where(sw, V * T * _bezier(_BX, u, deriv) / d_sw**deriv, 0.0)
                zd = np.where(sw, task.swing_height * _bezier(_BZ, u, deriv) / d_sw**deriv, 0.0)
        if deriv == 0:
            out[:, i, 0], out[:, i, 1], out[:, i, 2] = x, off[i, 1], z
        else:
            out[:, i, 0], out[:, i, 2] = xd, zd
    return out

"""The route a higher control level gives the gait: gait type, crab angle, speed, yaw rate,
and timed changes of the crab angle or of k_ev (the paper's examples change both mid-walk)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class Change:
    at_s: float
    crab_angle_deg: float | None = None
    k_ev: float | None = None


@dataclasses.dataclass(frozen=True)
class Route:
    gait: str = "crab"  # crab | circling | spinning
    crab_angle_deg: float = 0.0
    speed: float = 0.02
    distance: float = 2.0  # COG path length (crab, circling)
    turn_rate_deg_s: float = 0.0
    turn_deg: float = 90.0  # spinning: yaw to turn
    changes: tuple[Change, ...] = ()

    def crab_angle(self, t: float) -> float:
        a = self.crab_angle_deg
        for c in sorted(self.changes, key=lambda c: c.at_s):
            if c.at_s <= t and c.crab_angle_deg is not None:
                a = c.crab_angle_deg
        return math.radians(a)

    def k_ev(self, t: float, default: float) -> float:
        k = default
        for c in sorted(self.changes, key=lambda c: c.at_s):
            if c.at_s <= t and c.k_ev is not None:
                k = c.k_ev
        return k

    @property
    def omega(self) -> float:
        return math.radians(self.turn_rate_deg_s) if self.gait != "crab" else 0.0

    @property
    def body_speed(self) -> float:
        return 0.0 if self.gait == "spinning" else self.speed

    def nominal_duration(self) -> float:
        if self.gait == "spinning":
            return abs(self.turn_deg / self.turn_rate_deg_s)
        return self.distance / self.speed

    def nominal_path(self, dt: float = 0.1) -> np.ndarray:
        """(n, 3) x, y, yaw of the COG moving without stops from the origin heading +x."""
        n = int(math.ceil(self.nominal_duration() / dt)) + 1
        out = np.zeros((n, 3))
        x = y = yaw = 0.0
        for k in range(1, n):
            t = (k - 1) * dt
            a = self.crab_angle(t)
            v = self.body_speed
            x += v * dt * math.cos(yaw + a)
            y += v * dt * math.sin(yaw + a)
            yaw += self.omega * dt
            out[k] = (x, y, yaw)
        return out

"""When a damaged robot counts as recovered (issue 44): a trial that walks forward at least
at the target speed without falling.

The target is the recovery kind's (docs/recovery.md): 50 cm in 10 s, 5 cm/s, for the
built-in hexapod (jethexa). Another robot's target is the same speed scaled by its leg
length (the sum of a leg's link lengths) against the hexapod's: a robot with legs twice as
long must walk twice as fast, as a dynamically similar gait would (the same Froude number
would scale by the square root; the issue asks for leg length, and this states it). An
uploaded robot's leg length is measured the same way on its model (app/robots/walkable.py
``leg_length_m``: joint anchor to joint anchor to the foot, the mean over its legs)."""

from __future__ import annotations

from typing import Any

from app.robots.catalog import get_robot

TARGET_M_S = 0.50 / 10.0  # the recovery target: 50 cm in 10 s
REFERENCE_ROBOT = "jethexa"


def leg_length_m(robot: str, stored: Any = None) -> float:
    """A robot's leg length (m): a built-in robot's sum of its leg's link lengths, or that of
    the uploaded robot ``stored`` (app/robots/legmap.py ``Robot``) measured on its model."""
    if stored is not None:
        from app.robots.walkable import leg_length_m as measured

        return measured(stored)
    return float(sum(get_robot(robot).geometry.link_lengths))


def target_speed(robot: str, stored: Any = None) -> float:
    """The recovery target (m/s) of a built-in robot, or of the uploaded robot ``stored``
    (module doc)."""
    return TARGET_M_S * leg_length_m(robot, stored) / leg_length_m(REFERENCE_ROBOT)


def recovered(forward_m: float, fell: bool, duration_s: float, robot: str, stored: Any = None) -> bool:
    """The definition, in one place: forward speed at least the target and no fall."""
    return (not fell) and duration_s > 0 and forward_m / duration_s >= target_speed(robot, stored)

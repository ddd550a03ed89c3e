"""When a damaged robot counts as recovered (issue 44): a trial that walks forward at least
at the target speed without falling.

The target is the recovery kind's (docs/recovery.md): 50 cm in 10 s, 5 cm/s, for the
built-in hexapod (jethexa). Another robot's target is the same speed scaled by its leg
length (the sum of a leg's link lengths) against the hexapod's: a robot with legs twice as
long must walk twice as fast, as a dynamically similar gait would (the same Froude number
would scale by the square root; the issue asks for leg length, and this states it)."""

from __future__ import annotations

from app.robots.catalog import get_robot

TARGET_M_S = 0.50 / 10.0  # the recovery target: 50 cm in 10 s
REFERENCE_ROBOT = "jethexa"


def leg_length_m(robot: str) -> float:
    """A built-in robot's leg length: the sum of its leg's link lengths (m)."""
    return float(sum(get_robot(robot).geometry.link_lengths))


def target_speed(robot: str) -> float:
    """The recovery target (m/s) of a built-in robot (module doc)."""
    return TARGET_M_S * leg_length_m(robot) / leg_length_m(REFERENCE_ROBOT)


def recovered(forward_m: float, fell: bool, duration_s: float, robot: str) -> bool:
    """The definition, in one place: forward speed at least the target and no fall."""
    return (not fell) and duration_s > 0 and forward_m / duration_s >= target_speed(robot)

"""Robots gaitmend knows by name: one line per built-in robot, whose folder under
app/robots/ holds its builder and its entry (nominal stance and gait)."""

from __future__ import annotations

from app.robots.hexapod.entry import JETHEXA, RobotEntry

ROBOTS: dict[str, RobotEntry] = {JETHEXA.name: JETHEXA}


def get_robot(name: str) -> RobotEntry:
    try:
        return ROBOTS[name]
    except KeyError:
        raise KeyError(f"unknown robot {name!r}; known: {sorted(ROBOTS)}") from None

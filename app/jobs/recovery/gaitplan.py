"""The gait a trace was planned to walk, for the gait diagrams of the page
(views.gait_diagram) and of the bundle (plots.gait_diagram), and their one colour scheme."""

from __future__ import annotations

import numpy as np

# One colour scheme for the gait diagram on the page and in the bundle (plots.gait_diagram):
# measured swing (foot in the air) in the run's colour, measured support in the same colour
# faded, the plan's swing (the gait sequence over the period) as a dark grey bar beside them.
GAIT_SCHEME = {"support_alpha": 0.25, "planned": "#374151"}


def faded(hex_color: str) -> str:
    """The support colour of a run: its colour at GAIT_SCHEME's alpha (also in the legend)."""
    h = hex_color.lstrip("#")
    r, g, b = (int(h[i:i + 2], 16) for i in (0, 2, 4))
    return f"rgba({r},{g},{b},{GAIT_SCHEME['support_alpha']})"


PLANS = {"best": "gait", "baseline": "baseline"}  # trace -> where the summary keeps its sequence


def plan_of(summary: dict, name: str) -> tuple[dict | None, float | None]:
    """The gait sequence a trace was planned to walk and the period (s); (None, None) if unknown."""
    period = (summary.get("gait") or {}).get("period_s")
    where = PLANS.get(name)
    gait = summary.get("gait") if where == "gait" else (summary.get("baseline") or {}).get("gait") if where else None
    return (gait, period) if gait and period and "swing_phases" in gait else (None, None)


def planned_swings(gait: dict, period: float, leg: int, t_end: float) -> list[tuple[float, float]]:
    """When ``leg`` is planned to swing in [0, t_end]: its phase's 1/sigma of every period
    (app/jobs/recovery/trajectory.py, the walk's first period starting at t = 0)."""
    p = gait["swing_phases"].get(str(leg))
    if p is None:
        return []
    sigma = gait["sigma"]
    out = []
    for c in range(int(np.ceil(t_end / period)) + 1):
        s = (c + p / sigma) * period
        e = min(s + period / sigma, t_end)
        if s < t_end:
            out.append((s, e))
    return out

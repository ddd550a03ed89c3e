"""The gait diagram shows the planned swing beside the measured contact, on the page and in
the bundle's PNG, in one colour scheme (issue 25): a foot the plan lifts but that never
leaves the ground shows a planned bar with no measured swing under it."""

import numpy as np
from PIL import Image

from app.jobs.recovery import plots, views
from app.jobs.recovery.gaitplan import GAIT_SCHEME, faded, plan_of, planned_swings

TRIPOD = {"name": "tripod", "sigma": 2, "swing_phases": {"1": 0, "2": 1}, "groups": [[1], [2]]}


def trace() -> dict:
    """1.2 s at 10 ms: leg 1 swings as planned (first half of each 0.6 s period), leg 2 never lifts."""
    t = np.arange(0, 1.2, 0.01)
    leg1 = np.mod(t / 0.6, 1.0) >= 0.5
    return {"time_s": t, "foot_contact": np.stack([leg1, np.ones_like(leg1)], axis=1), "legs": np.array([1, 2])}


def summary() -> dict:
    return {"gait": TRIPOD | {"period_s": 0.6}, "baseline": {"gait": TRIPOD}}


def test_planned_swings_follow_the_sequence():
    assert planned_swings(TRIPOD, 0.6, 2, 1.2) == [(0.3, 0.6), (0.8999999999999999, 1.2)]
    assert planned_swings(TRIPOD, 0.6, 1, 1.0) == [(0.0, 0.3), (0.6, 0.8999999999999999)]
    assert planned_swings(TRIPOD, 0.6, 3, 1.0) == []
    assert plan_of(summary(), "baseline") == (TRIPOD, 0.6) and plan_of(summary(), "other") == (None, None)


def test_page_shows_plan_beside_contact_in_the_run_colour():
    fig = views.gait_diagram(summary(), {"best": trace()})["figure"]
    by = {d["name"]: d for d in fig["data"]}
    color = views.RUNS["best"][1]
    swing, support, plan = by["recovered gait: swing (measured)"], by["recovered gait: support (measured)"], \
        by["recovered gait: planned swing"]
    assert swing["marker"]["color"] == color and support["marker"]["color"] == faded(color)
    assert faded(color).endswith(f",{GAIT_SCHEME['support_alpha']})") and plan["marker"]["color"] == GAIT_SCHEME["planned"]
    assert "recovered · leg 2" in plan["y"] and "recovered · leg 2" not in swing["y"]  # planned, never lifted
    assert plan["offset"] >= swing["offset"] + swing["width"]  # beside, not on top of each other


def test_bundle_png_uses_the_same_colours(tmp_path):
    color = views.RUNS["best"][1]
    png = [p for p in plots.gait_diagram(trace(), tmp_path, color=color, plan=(TRIPOD, 0.6)) if p.suffix == ".png"][0]
    px = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3).astype(int)

    def share(hex_color: str) -> float:
        rgb = np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])
        return float((np.abs(px - rgb).sum(axis=1) < 12).mean())

    assert share(color) > 0.005 and share(GAIT_SCHEME["planned"]) > 0.005

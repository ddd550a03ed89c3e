"""A tipping job's summary for the view and figure tests: without recovery the robot tips
over at 12 s; with recovery the judgment fires at 5 s on edge a35 and leg 6 lands at 6.2 s."""

from __future__ import annotations


def tipping_summary() -> dict:
    return {"threshold_deg": 20.0, "adjustment_leg": 6,
            "runs": {"no_recovery": {"tipped": True, "tipped_at_s": 12.0, "adjustments": []},
                     "recovery": {"tipped": False, "detection_time_s": 5.0,
                                  "adjustments": [{"detect_time_s": 5.0, "edge": "a35", "leg": 6, "land_time_s": 6.2,
                                                   "foothold_body_m": [-2.4, -2.4, -1.7], "foothold_label": "D",
                                                   "margin_after_landing_deg": 35.0, "lands_before_tip": True}]}}}

"""The dashboard views each kind builds (app/jobs/<kind>/views.py) and the shared evidence
tables (app/jobs/viewkit.py): what the page draws is right before it reaches a browser."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.jobs import viewkit as kit
from app.jobs.multigait import views as mg
from app.jobs.recovery import views as rec
from app.jobs.tipping import views as tip
from tests.jobs.tipping.cases import tipping_summary


def strict_json(x) -> str:
    return json.dumps(x, allow_nan=False)  # the page gets JSON: no NaN may slip through


def tipping_case():
    t = np.round(np.arange(0, 20, 0.02), 2)
    fall = t >= 12.0
    base = {"time_s": t, "fasm_deg": np.where(fall, -180.0, 30 - 2 * t), "ssm_m": 0.5 - 0.01 * t, "nesm_m": 0.2 + 0 * t,
            "foot_fz_n": np.tile(np.arange(1, 7) * 1e3, (len(t), 1)), "tilt_rel_deg": np.where(fall, 120.0, 0.0),
            "platform_tilt_deg": 2 * t}
    reco = dict(base, fasm_deg=np.where(t > 6, 35.0, 30 - 2 * t), tilt_rel_deg=0 * t)
    return tipping_summary(), {"no_recovery": base, "recovery": reco}


def test_tipping_margin_has_threshold_detection_and_stops_at_the_fall():
    summary, traces = tipping_case()
    views = tip.views(summary, traces)
    strict_json(views)
    margin = next(v for v in views if v["id"] == "margin")["figure"]
    names = [d["name"] for d in margin["data"]]
    assert "threshold 20°" in names and "FASM with recovery" in names and "FASM without recovery" in names
    thr = next(d for d in margin["data"] if d["name"].startswith("threshold"))
    assert thr["y"] == [20.0, 20.0]
    without = next(d for d in margin["data"] if d["name"] == "FASM without recovery")
    assert max(without["x"]) <= 12.0 and min(without["y"]) > -180  # the line ends where the robot fell
    notes = [a["text"] for a in margin["layout"]["annotations"]]
    assert any(n.startswith("detected 5.00 s") for n in notes) and any("leg 6 lands" in n for n in notes)
    hidden = [d["name"] for d in margin["data"] if d.get("visible") == "legendonly"]
    assert {"SSM with recovery (m)", "NESM with recovery (m)"} <= set(hidden)
    forces = next(v for v in views if v["id"] == "forces")["figure"]
    legend = [d["name"] for d in forces["data"] if d.get("showlegend", True)]
    assert legend == [f"leg {i}" for i in range(1, 7)]  # numbered as the paper, from 1
    leg6 = next(d for d in forces["data"] if d["name"] == "leg 6")
    assert leg6["y"][0] == pytest.approx(6.0)  # kN


def test_tipping_sweep_is_polar_in_percent():
    summary, traces = tipping_case()
    summary["sweep"] = {"directions_deg": [0.0, 90.0, 180.0, 270.0], "success_rate": [1.0, 0.5, None, 0.0],
                        "tip_rate_without_recovery": [1.0, 1.0, 0.5, 0.0], "overall_success_rate": 0.5}
    sweep = next(v for v in tip.views(summary, traces) if v["id"] == "sweep")["figure"]
    assert sweep["data"][0]["type"] == "barpolar" and sweep["data"][0]["r"] == [100.0, 50.0, None, 0.0]
    strict_json(sweep)


def multigait_case():
    pos = [[10, 10, 0.5], [12, 10, 0.5], [14, 11, 0.5], [12, 8, 0.5], [16, 12, 0.5]]
    parent = [-1, 0, 1, 0, 2]
    summary = {"cost": "coverage", "gaits": 2, "result": {"final_best": 4.2, "initial_best": 3.0},
               "map": {"name": "column", "width_mu": 48, "height_mu": 27, "cell_mu": 1.0, "flat": True,
                       "obstacles": [[20, 5, 24, 20]], "terrain_boxes": [], "start": [10, 10, 0], "goal": [25, 10, 0.5]},
               "tree": {"pos_mu": pos, "parent": parent, "gait": [0, 0, 1, 1, 0], "plan_node": 4},
               "per_gait": [{"gait": 1, "distance_mu": 2.0, "rotation_deg": 5.0, "end_mu": [2.0, 0.1]},
                            {"gait": 2, "distance_mu": 1.0, "rotation_deg": -40.0, "end_mu": [0.5, 0.8]}],
               "reuse": {"column_same": {"distance_mu": {"mean": 10.0, "std": 1.0}, "coverage_pct": {"mean": 2.0, "std": 0.1}}}}
    traces = {"composition": {"time_s": np.arange(4.0), "depth": np.array([0, 1, 2, 3]),
                              "composed_mu": np.zeros((4, 3)), "simulated_mu": np.ones((4, 3)) * 0.1}}
    return summary, traces


def test_multigait_map_has_obstacles_tree_by_gait_plan_and_start():
    summary, traces = multigait_case()
    views = mg.views(summary, traces)
    strict_json(views)
    m = next(v for v in views if v["id"] == "map")["figure"]
    names = [d["name"] for d in m["data"]]
    assert {"tree: gait 1", "tree: gait 2", "start"} <= set(names)
    plan = next(d for d in m["data"] if d["name"].startswith("plan ("))
    assert "3 gaits: 1 → 2 → 1" in plan["name"]  # root -> 1 -> 2 -> 4: gaits 0, 1, 0 (+1)
    assert plan["x"] == [10.0, 12.0, 12.0, 14.0, 14.0, 16.0]
    assert any(s["type"] == "rect" and s["x0"] == 20 for s in m["layout"]["shapes"])  # the column
    assert m["layout"]["yaxis"]["scaleanchor"] == "x"
    assert "goal" not in names  # a coverage run has no goal to draw
    # never a non-time column against time: the composition check is against node depth
    comp = next(v for v in views if v["id"] == "composition")["figure"]
    assert comp["layout"]["xaxis"]["title"]["text"].startswith("node depth")
    for v in views:
        if "figure" in v:
            for k, ax in v["figure"]["layout"].items():
                if k.startswith("xaxis") and "time" in (ax.get("title") or {}).get("text", ""):
                    pytest.fail(f"{v['id']} plots against time")


def test_multigait_axis_units_and_direction_follow_the_cost():
    from app.jobs.multigait.present import history_axis

    assert history_axis({"cost": "coverage"})["better"] == "higher"
    dist = history_axis({"cost": "distance"})
    assert dist["better"] == "lower" and "mu" in dist["y"] and "F" not in dist["y"]


def recovery_case(y_best, yaw_best):
    def m(x, y, yaw, fell=False):
        return {"metrics": {"x_f_m": x, "y_f_m": y, "yaw_f_deg": yaw, "roll_amp_deg": 3.0, "pitch_amp_deg": 4.0,
                            "fell": fell}}

    best = m(0.01, y_best, yaw_best) | {"fitness": 50.0}
    base = m(0.03, 0.10, 2.0) | {"fitness": 5.0}
    return {"best": best, "baseline": base, "gait": None}


def test_recovery_table_marks_better_worse_and_the_target():
    table = rec.table_two(recovery_case(0.62, 14.0))["table"]
    recovered = table["rows"][1]
    lateral, forward, yaw = recovered[1], recovered[2], recovered[3]
    assert forward["better"] is True and forward["met"] is True  # 62 cm >= 50 cm
    assert lateral["better"] is True and lateral["met"] is True
    assert yaw["better"] is False and yaw["met"] is False  # 14 deg: worse than 2 deg, outside 10
    assert recovered[-1]["met"] is False and recovered[-1]["value"] == "not met"
    short = rec.table_two(recovery_case(0.30, 1.0))["table"]["rows"][1]
    assert short[2]["met"] is False and short[-1]["value"] == "not met"
    strict_json(table)


def test_recovery_gait_diagram_labels_every_leg():
    t = np.linspace(0, 2, 201)
    contact = np.stack([(np.sin(2 * np.pi * t + k) > 0) for k in range(4)], axis=1)
    tr = {"time_s": t, "foot_contact": contact, "legs": np.array([2, 3, 4, 5])}
    gd = rec.gait_diagram({"gait": None}, {"best": tr, "baseline": tr})["figure"]
    ticks = gd["layout"]["yaxis"]["tickvals"]
    assert len(ticks) == 8 and gd["layout"]["yaxis"]["ticktext"] == ticks
    assert "recovered · leg 2" in ticks and "tripod · leg 5" in ticks


def test_swing_intervals():
    t = np.arange(6.0)
    assert kit.swing_intervals(t, [1, 0, 0, 1, 0, 1]) == [(1.0, 3.0), (4.0, 5.0)]
    assert kit.swing_intervals(t, [0, 0, 1, 1, 1, 0]) == [(0.0, 2.0), (5.0, 5.0)]


def test_evidence_tables_mark_targets():
    summary = {"controls": [{"name": "random_search", "label": "random search", "evaluations": 60,
                             "metrics": {"best": 1.5, "fell": False}, "target_met": False, "note": "same budget"},
                            {"name": "baseline", "label": "nominal", "evaluations": 1, "metrics": {"best": 0.1},
                             "target_met": None}],
               "robustness": {"target": "forward >= 50 cm", "met": 1, "total": 2,
                              "cases": [{"name": "dt_half", "label": "dt / 2", "metrics": {"y_cm": 55.0}, "target_met": True},
                                        {"name": "friction_0.7", "label": "friction x 0.7", "metrics": {"y_cm": float("nan")},
                                         "target_met": False}],
                              "spread": {"y_cm": {"min": 40.0, "max": 55.0, "nominal": 52.0}}}}
    c = kit.controls_panel(summary)["table"]
    assert c["rows"][0][0]["note"] == "same budget" and c["rows"][0][-1]["met"] is False
    assert c["rows"][0][3] == "no" and c["rows"][1][-1]["text"] == "–"
    r = kit.robustness_panel(summary)
    assert r["summary"] == {"met": 1, "total": 2} and r["table"]["rows"][1][1] is None  # NaN -> gap
    assert [row[-1]["met"] for row in r["table"]["rows"]] == [True, False]
    strict_json(r)
    assert kit.controls_panel({}) is None and kit.robustness_panel({"robustness": {"cases": []}}) is None

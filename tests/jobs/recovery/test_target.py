"""The recovery target is one object (metrics.TARGET): the summary, the headline, the CLI
tables, the dashboard, the atlas and the experiments' tables all judge a gait by it, so a
gait that fell can never read "met" anywhere, however far and straight it walked."""

from app.jobs.recovery import atlas, experiments, present, views
from app.jobs.recovery.metrics import TARGET, meets_target, target_checks

# walked 90 cm, 1 cm sideways, 1 deg of yaw: every distance condition holds, but it fell
FELL_FAR = {"x_f_m": 0.01, "y_f_m": 0.9, "yaw_f_deg": 1.0, "roll_amp_deg": 2.0, "pitch_amp_deg": 2.0,
            "tilt_max_deg": 70.0, "under_3_feet_frac": 0.1, "fell": True}
STANDING = FELL_FAR | {"y_f_m": 0.1, "fell": False}


def summary_of(best: dict) -> dict:
    return {"kind": "recovery", "robot": "jethexa", "damage": {"lost_legs": [1, 6]},
            "gait": {"name": "modified_pentagonal", "sigma": 4, "groups": []},
            "best": {"metrics": best, "fitness": -1.0, "target_met": TARGET.met(best)},
            "baseline": {"metrics": STANDING, "fitness": 0.01, "target_met": TARGET.met(STANDING)},
            "target": {"text": TARGET.text, "best_met": TARGET.met(best), "baseline_met": TARGET.met(STANDING)},
            "controls": [{"name": "baseline", "label": "nominal tripod", "metrics": STANDING, "target_met": False,
                          "evaluations": 1, "note": "", "fitness": 0.01}],
            "robustness": {"target": TARGET.text, "met": 0, "total": 1, "spread": {},
                           "cases": [{"name": "dt_half", "label": "timestep halved", "metrics": best,
                                      "target_met": TARGET.met(best)}]}}


def test_a_fall_fails_the_target_whatever_the_distances():
    checks = target_checks(FELL_FAR)
    assert checks == {"forward": True, "lateral": True, "yaw": True, "upright": False}
    assert TARGET.met(FELL_FAR) is False and meets_target(FELL_FAR) is False
    assert TARGET.met(FELL_FAR | {"fell": False}) is True
    assert "no fall" in TARGET.text


def test_headline_and_cli_tables_say_not_met_for_a_gait_that_fell():
    s = summary_of(FELL_FAR)
    rows = {r["label"]: r for r in present.headline(s)}
    assert rows["recovery target"]["value"] == "not met" and rows["recovery target"]["met"] is False
    assert rows["recovery target"]["target"] == TARGET.text
    assert rows["fell"]["met"] is False
    assert rows["forward distance"]["met"] is True  # the condition itself holds; the target does not
    after = present.summary_tables(s)[0]["rows"][1]
    assert after[0] == "after recovery" and after[-1] == "False"
    assert TARGET.text in present.summary_tables(s)[0]["notes"][0]


def test_the_dashboard_says_not_met_for_a_gait_that_fell():
    panel = views.table_two(summary_of(FELL_FAR))
    recovered = panel["table"]["rows"][1]
    assert recovered[-1]["value"] == "not met" and recovered[-1]["met"] is False
    assert recovered[-3]["value"] == "yes" and recovered[-3]["met"] is False  # the fell column
    assert TARGET.text in panel["caption"] and TARGET.text in panel["table"]["columns"][-1]
    upright = views.table_two(summary_of(FELL_FAR | {"fell": False}))["table"]["rows"][1]
    assert upright[-1]["value"] == "met"


def test_the_atlas_and_the_experiments_count_a_fall_as_not_met():
    point = {"status": "succeeded", "spec": {"damage": {"lost_legs": [1, 6]}}, "summary": summary_of(FELL_FAR)}
    assert "| 0/1 |" in atlas.table([point])
    s = summary_of(FELL_FAR) | {"timestep_s": 0.002, "timing": {"wall_s": 1.0}}
    s["best"] |= {"params": {}}
    row = experiments._row((1, 6), 0, 1, 4, s)
    assert row["target_met"] is False and row["robustness"] == {
        "met": 0, "total": 1, "cases": {"dt_half": {k: FELL_FAR[k] for k in ("x_f_m", "y_f_m", "yaw_f_deg",
                                                                            "tilt_max_deg", "fell")}
                                        | {"target_met": False}}}
    md = experiments.table_markdown([row], 1, 4)
    line = next(ln for ln in md.splitlines() if ln.startswith("| Legs 1 & 6 lost | modified_pentagonal"))
    assert "| 1/1 | 0/1 |" in line  # fell after: 1 of 1 runs; target met: 0 of 1
    per_case = next(ln for ln in md.splitlines() if ln.startswith("| Legs 1 & 6 lost |") and ln != line)
    assert per_case.split("|")[2].strip().endswith("; 0/1")  # the nominal column, judged by TARGET
    assert TARGET.text in md

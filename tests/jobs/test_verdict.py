"""The verdict's robustness part (issue 46): the held-out random models lead, with their 95 %
Wilson interval and falls, then the named cases and the timestep checks as separate counts;
below KEEP_MIN kept or above FALL_MAX fallen, the first sentence calls the gait fragile.
Read from the shared evidence records only: any kind whose robustness block carries a
held-out set gets the same words (no kind is named here)."""

from __future__ import annotations

import pytest

from app.jobs import verdict
from app.jobs.records import HeldOut
from verdict_support import summary

def test_the_held_out_record_reads_kept_judged_and_falls():
    h = HeldOut.from_json(summary(5, 14)["robustness"]["held_out"])
    assert (h.n, h.met, h.judged, h.fell, h.share, h.fall_share) == (20, 5, 20, 14, 0.25, 0.7)
    assert HeldOut.from_json({"n": 0, "met": 0}) is None
    assert HeldOut.from_json({"n": 10, "met": 9, "fell": 1}).fell == 1  # the block's own count wins
    assert HeldOut.from_json({"n": 10, "met": 9}).fell is None  # no models, no count: unknown, not 0


def test_a_fragile_gait_says_so_first_and_why():
    v = verdict.verdict_of(summary(5, 14), [])
    s = v["sentence"]
    assert s.startswith("Fragile: falls on 14 of 20 models like yours and keeps the target on only 5 of 20: "
                        "do not take it to the robot as it is."), s
    assert "5 of 20 held-out random models keep the target (95 % interval 11–47 %), 14 fall." in s
    # then the named cases and the timestep checks, each its own count
    assert "Of the robustness re-runs, 1 of 2 named cases and 2 of 2 timestep checks meet the target." in s
    assert s.index("held-out") < s.index("named cases") < s.index("timestep checks")
    rob = v["robustness"]
    assert [g["name"] for g in rob["groups"]] == ["held_out", "physical", "numerics"]
    assert rob["held_out"]["fragile"] and rob["held_out"]["interval"] == pytest.approx([0.1119, 0.4687], abs=1e-4)


def test_a_robust_gait_states_the_same_figure_without_the_warning():
    s = verdict.verdict_of(summary(19, 1), [])["sentence"]
    assert not s.startswith("Fragile") and "Fragile" not in s
    assert "19 of 20 held-out random models keep the target (95 % interval 76–99 %), 1 fall." in s
    assert s.startswith("Target met on the model it was searched on.")


@pytest.mark.parametrize("met,fell,fragile,why", [
    (16, 0, False, []),  # 80 % kept is not below 80 %
    (15, 0, True, ["keeps the target on only 15 of 20"]),
    (19, 1, False, []),  # 5 % falls is not above 5 %
    (18, 2, True, ["falls on 2 of 20 models like yours"]),
    (0, 0, True, ["keeps the target on 0 of 20"]),
])
def test_the_thresholds(met, fell, fragile, why):
    assert (verdict.KEEP_MIN, verdict.FALL_MAX) == (0.80, 0.05)
    h = verdict.verdict_of(summary(met, fell), [])["robustness"]["held_out"]
    assert h["fragile"] is fragile and h["why"] == why
    assert verdict.FRAGILE_RULE in h["rule"] and "80 %" in h["rule"] and "5 %" in h["rule"]


def test_unjudged_models_are_not_counted_as_kept_or_missed():
    h = verdict.verdict_of(summary(3, 1, unjudged=16), [])["robustness"]["held_out"]
    assert (h["judged"], h["met"]) == (4, 3)
    assert h["text"].startswith("3 of 4 judged held-out random models keep the target")
    none = verdict.verdict_of(summary(0, 0, unjudged=20), [])["robustness"]["held_out"]
    assert none["text"] == "20 held-out random models: the target judges none of them, 0 fall"
    assert not none["fragile"] and none["interval"] is None


def test_without_a_held_out_set_the_counts_stay_apart():
    v = verdict.verdict_of(summary(0, 0, held=False), [])
    assert v["robustness"]["held_out"] is None and "held-out" not in v["sentence"]
    assert v["sentence"] == ("Target met. Of the robustness re-runs, 1 of 2 named cases and 2 of 2 timestep "
                             "checks meet the target.")


def test_brief_and_study_carry_the_held_out_statement():
    b = verdict.brief(verdict.verdict_of(summary(5, 14), []))
    assert b["held_out"]["text"].startswith("5 of 20 held-out") and b["held_out"]["fragile"] is True
    assert b["held_out"]["headline"].startswith("Fragile: falls on 14 of 20")
    sv = verdict.study_verdict([verdict.verdict_of(summary(5, 14), []), verdict.verdict_of(summary(19, 1), [])])
    h = sv["held_out"]
    assert (h["met"], h["n"], h["fell"], h["points"]) == (24, 40, 15, 2) and h["fragile"]
    assert verdict.study_verdict([verdict.verdict_of(summary(0, 0, held=False), [])])["held_out"] is None

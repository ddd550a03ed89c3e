"""Stored answers judged again on today's worlds (issue 47): the rewritten entries are what
the job's robustness block walks, the count follows, and a row whose answer no longer walks
as stored is left alone."""

import copy
import json
from pathlib import Path

import pytest

from app.jobs.recovery.reproduce.rejudge import FLOOR_CHANGE, old_floor_note, rejudge_rows


@pytest.fixture(scope="module")
def rows():
    table2 = json.loads(Path("docs/table2.json").read_text())
    return [r for r in table2 if r["lost_legs"] == [4] and r["seed"] in (0, 1) and r["timestep_s"] == 0.001]


def test_a_case_walked_again_is_the_robustness_blocks_walk(rows):
    """The documented rough_terrain entries (walked on today's floor) come back when spoiled;
    the other cases are left as they were; a row whose answer walks otherwise is skipped."""
    spoiled = copy.deepcopy(rows)
    for r in spoiled:
        r["robustness"]["cases"]["rough_terrain"] = {"x_f_m": 9.0, "y_f_m": 0.0, "yaw_f_deg": 90.0,
                                                     "tilt_max_deg": 0.0, "fell": True, "target_met": False}
        r["robustness"]["met"] = 0
        r.pop("rejudged", None)
    other = copy.deepcopy(spoiled[1])
    other["best"]["y_f_m"] += 0.01  # not the stored walk
    n, skipped = rejudge_rows(spoiled + [other], ["rough_terrain"], log=lambda s: None)
    assert n == 2 and skipped == [other] and "rejudged" not in other
    for new, doc in zip(spoiled, rows):
        for key, v in doc["robustness"]["cases"]["rough_terrain"].items():
            assert new["robustness"]["cases"]["rough_terrain"][key] == pytest.approx(v, abs=1e-6)
        assert new["robustness"]["met"] == sum(c["target_met"] for c in doc["robustness"]["cases"].values())
        assert new["robustness"]["cases"]["dt_half"] == doc["robustness"]["cases"]["dt_half"]
        assert new["rejudged"]["cases"] == ["rough_terrain"]


def test_runs_before_the_floor_change_are_named():
    before, after = {"finished_at": "2026-12-01T00:00:00Z"}, {"finished_at": FLOOR_CHANGE["at"]}
    assert old_floor_note([after], "x", "cmd") == []
    [text, _] = old_floor_note([before, after], "its held-out figures", "cmd")
    assert "1 of 2 runs" in text and FLOOR_CHANGE["commit"] in text and "its held-out figures are" in text

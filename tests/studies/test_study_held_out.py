"""The study page's verdict over the seeds carries the held-out figure (issue 46): a column of
the held-out random models kept over each group's points, with their falls, worded as the job
page words it, marked worse when fragile, its value the share (the page sorts by it)."""

from __future__ import annotations

from types import SimpleNamespace

from app.jobs.verdict import FRAGILE_RULE, verdict_of
from app.studies.views import verdict_panel
from verdict_support import summary


def _kind():
    return SimpleNamespace(verdict=lambda s: verdict_of(s, []), headline=lambda s: [])


def _point(group: str, met: int, fell: int) -> dict:
    return {"status": "succeeded", "overrides": {"damage.lost_legs": group}, "spec": {}, "summary": summary(met, fell)}


def test_the_verdict_table_has_a_sortable_held_out_column():
    points = [_point("a", 5, 14), _point("a", 6, 13), _point("b", 19, 1), _point("b", 20, 0)]
    panel = verdict_panel(_kind(), points, ["damage.lost_legs"])
    cols = panel["table"]["columns"]
    assert cols[:4] == ["group", "target met", "held-out models kept", "re-runs met"]
    cells = {row[0]: row[2] for row in panel["table"]["rows"]}
    a, b = (next(v for k, v in cells.items() if g in k) for g in ("a", "b"))
    assert a["text"] == "11 of 40, 27 fell" and a["value"] == 11 / 40 and a["better"] is False
    assert a["note"].startswith("11 of 40 held-out random models keep the target (95 % interval") and "fragile" in a["note"]
    assert b["text"] == "39 of 40, 1 fell" and "better" not in b and "fragile" not in b["note"]
    assert FRAGILE_RULE in panel["caption"] and "sort" in panel["caption"]


def test_without_a_held_out_set_the_column_says_so():
    p = {"status": "succeeded", "overrides": {}, "spec": {}, "summary": summary(0, 0, held=False)}
    row = verdict_panel(_kind(), [p], [])["table"]["rows"][0]
    assert row[2] == {"value": None, "text": "–"}


def test_points_the_target_does_not_judge_are_not_counted_as_missed():
    p = {"status": "succeeded", "overrides": {}, "spec": {}, "summary": summary(0, 2, unjudged=18)}
    cell = verdict_panel(_kind(), [p], [])["table"]["rows"][0][2]
    assert cell["text"] == "0 of 2, 2 fell"  # only the falls were judged
    q = {"status": "succeeded", "overrides": {}, "spec": {}, "summary": summary(0, 0, unjudged=20)}
    assert verdict_panel(_kind(), [q], [])["table"]["rows"][0][2]["text"] == "20 not judged, 0 fell"

"""The evidence protocol's records: what a kind writes is what a view reads back, the
spread keeps the range of every metric, and the phases share one progress bar and one
checkpoint."""

from __future__ import annotations

import pytest

from app.jobs import evidence as ev
from app.jobs.base import Cancelled, MemoryContext


def test_control_seed_is_its_own_stream():
    assert ev.control_seed(0) == 7919 and ev.control_seed(3) == 7922
    assert ev.control_seed(0) != 0


def test_standard_cases_and_groups():
    assert ev.case("dt_half").timestep_scale == 0.5 and ev.group_of("dt_quarter") == "numerics"
    assert ev.group_of("friction_0.7") == "physical" and ev.group_of("ground_error_+") == "physical"
    assert ev.case("mass_+10pct", "every link +10 %").label == "every link +10 %"
    with pytest.raises(KeyError, match="dt_half"):
        ev.case("dt_halved")


def test_records_round_trip_with_a_kinds_own_keys():
    row = {"name": "random_search", "label": "random", "fitness": 1.5, "metrics": {"y": 1.0}, "target_met": True,
           "evaluations": 30, "note": "same budget"}
    assert ev.ControlRow.from_json(row).to_json() == row
    block = {"target": "t", "cases": [{"name": "dt_half", "label": "h", "fitness": 2.0, "metrics": {"y": 0.9},
                                      "target_met": True},
                                     {"name": "friction_0.7", "label": "f", "metrics": {"y": 0.2}, "target_met": False}],
             "met": 1, "total": 2, "spread": {"y": {"min": 0.2, "max": 1.0, "nominal": 1.0}}, "sim_steps": 7}
    r = ev.Robustness.from_json(block)
    assert r.to_json() == block
    assert r.count("numerics") == (1, 1) and r.count("physical") == (0, 1)


def test_spread_covers_nominal_and_cases_and_skips_what_is_not_a_number():
    cases = [{"metrics": {"a": 2, "b": None, "ok": True}}, {"metrics": {"a": 5, "b": 1.5}}]
    s = ev.spread({"a": 3, "b": None, "ok": True, "name": "x"}, cases)
    assert s == {"a": {"min": 2.0, "max": 5.0, "nominal": 3.0}}
    s = ev.spread({"a": 3, "b": None}, cases, keys=["a", "b", "c"], as_float=False)
    assert s == {"a": {"min": 2, "max": 5, "nominal": 3}, "b": {"min": 1.5, "max": 1.5, "nominal": None}}


def test_target_is_one_test():
    t = ev.Target("forward >= 50 cm and no fall", lambda m: m["y"] >= 0.5 and not m["fell"])
    assert t.met({"y": 0.6, "fell": False}) and not t.met({"y": 0.6, "fell": True})


class _Ctx(MemoryContext):
    def __init__(self):
        super().__init__()
        self.reports = []
        self.cancel = False

    def progress(self, done, total, info):
        self.reports.append((done, total, info.get("phase")))

    def is_cancelled(self):
        return self.cancel


def test_phases_share_one_bar_and_one_checkpoint():
    ctx = _Ctx()
    phases = ev.Phases(ctx, {"search": 10, "robustness": 4})
    s = phases.context("search")
    s.progress(5, 10, {})
    s.save_checkpoint({"g": 1})
    r = phases.context("robustness")
    r.tick(2)
    assert ctx.reports == [(5, 14, "search"), (12, 14, "robustness")]
    assert ctx.load_checkpoint() == {"search": {"g": 1}}
    again = ev.Phases(ctx, {"search": 10, "robustness": 4})
    assert again.context("search").load_checkpoint() == {"g": 1}
    assert again.context("robustness").load_checkpoint() is None
    ctx.cancel = True
    with pytest.raises(Cancelled):
        r.tick()
    with pytest.raises(KeyError, match="search"):
        phases.context("controls")

"""Issue 24's measurement page: rendered from its committed ledger, resumable."""

import json
import shutil
from pathlib import Path

import pytest
from app.jobs.recovery.reproduce import loop_check

ROOT = Path(__file__).resolve().parents[3]


def test_the_page_renders_every_answer_both_ways_with_the_issues_bar():
    data = json.loads((ROOT / loop_check.JSON).read_text())
    text = loop_check.render([data])
    for lost in ("legs 1 & 6", "legs 3 & 4", "leg 1 ", "leg 4 "):
        assert f"| {lost.strip()} | open loop |" in text and f"| {lost.strip()} | closed loop |" in text
        assert f"| {lost.strip()} | closed loop + balance |" in text
    assert "Issue 24's bar" in text and text.count(" met") >= 4
    runs = data["runs"]
    assert len(runs) == 4 and all(len(r["result"]["closed_loop"]["held_out"]) >= 20 for r in runs)
    # the same held-out models every way
    assert all(len(r["result"]["open_loop"]["held_out"]) == len(r["result"]["closed_loop"]["held_out"])
               == len(r["result"]["balance"]["held_out"]) for r in runs)
    assert all(r["result"]["balance_law"]["balance_gain"] > 0 and r["result"]["law"]["balance_gain"] == 0 for r in runs)
    assert "**Balance**" in text


def test_the_wilson_interval_holds_the_share():
    lo, hi = loop_check.wilson(34, 40)
    assert lo < 34 / 40 < hi and 0 <= lo and hi <= 1
    assert loop_check.wilson(40, 40)[1] == pytest.approx(1.0)


def test_a_rerun_skips_the_answers_already_in_the_ledger(tmp_path, monkeypatch):
    committed = {r["name"]: r["result"] for r in json.loads((ROOT / loop_check.JSON).read_text())["runs"]}
    calls = []

    def canned(lost, params, seed, n, update):
        calls.append(tuple(lost))
        return committed["legs " + "-".join(map(str, lost))]

    monkeypatch.setattr(loop_check, "walk_both_ways", canned)
    params = loop_check.LoopParams(held_out=20, json_out=tmp_path / "ledger.json")
    first = loop_check.run_loop_check(params, log=lambda m: None)
    assert len(calls) == 4 and "Issue 24's bar" in first
    monkeypatch.setattr(loop_check, "walk_both_ways", lambda *a: pytest.fail("re-ran an answer already there"))
    assert loop_check.run_loop_check(params, log=lambda m: None) == first

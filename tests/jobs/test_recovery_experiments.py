"""The Table II reproduction writes each run as it finishes and resumes after a stop."""

import json

from app.jobs.recovery import experiments as reproduce


def test_table2_resumes_and_formats(tmp_path, monkeypatch):
    monkeypatch.setattr(reproduce, "SCENARIOS", [(3, 4)])
    raw = tmp_path / "t2.json"
    calls = []
    md = reproduce.run_table2(seeds=1, generations=1, population=4, raw_path=raw, log=calls.append)
    rows = json.loads(raw.read_text())
    assert len(rows) == 1 and rows[0]["lost_legs"] == [3, 4] and len(calls) == 1
    assert "| Legs 3 & 4 lost | modified_pentagonal | 1 |" in md
    assert "10.1 / 52.7 / 5.8" in md  # the paper's row beside ours
    # A second call finds the run on disk and does not simulate again.
    md2 = reproduce.run_table2(seeds=1, generations=1, population=4, raw_path=raw, log=calls.append)
    assert md2 == md and len(calls) == 1

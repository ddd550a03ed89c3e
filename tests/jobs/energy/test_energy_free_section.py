"""The free-timing section of docs/energy.md from its ledger (issue 28): the GA's best
against Table 1's trot and the equal-budget random search, the infeasible share of each
search, and the earlier hand-typed record's three statements each set against the data
(small hand-made results here, no optimisation)."""

from __future__ import annotations

import json

import pytest

from app.jobs.energy.reproduce import experiments as ex
from app.jobs.energy.spec import EnergySpec


def result(ga_j: float, rs_j: float, ga_cot: float, feasible: list[float], rs_feasible: list[float]) -> dict:
    hist = [{"generation": g, "best": -ga_j, "random_search_best": -rs_j, "feasible_share": f,
             "random_search_feasible_share": r} for g, (f, r) in enumerate(zip(feasible, rs_feasible))]
    return {"gait": {"period_s": 0.8123, "duty": [0.5, 0.61, 0.55, 0.7]}, "links_m": [0.06, 0.3, 0.3], "J": ga_j,
            "feasible": True, "cot": {"final": ga_cot}, "physics": {"stays_up": False, "cot": None, "speed_m_s": 0.4},
            "search": {"population": 16, "generations": 5, "evaluations": 96},
            "controls": [{"name": "random_search", "metrics": {"J": rs_j, "feasible": True, "cot_final": 0.9}},
                         {"name": "paper_table1", "metrics": {"J": 1.1, "feasible": True, "cot_final": 1.031}}],
            "history": hist}


def ledger(r: dict) -> dict:
    spec = ex.free_spec(ex.FreeParams())
    return {"schema": 1, "experiment": "energy-free", "command": ex.FREE_COMMAND, "params": {}, "code_version": "v",
            "planned": 1, "runs": [{"name": "free seed 0", "key": "k", "spec": spec, "seed": 0, "code_version": "v",
                                    "wall_s": 300.2, "cpu_s": 40.0, "result": r}], "superseded": []}


def test_the_spec_is_the_issues_small_free_run():
    spec = ex.free_spec(ex.FreeParams())
    assert spec == {"kind": "energy", "gait": {"family": "free"}, "search": {"population": 16, "generations": 5, "seed": 0}}
    parsed = EnergySpec.parse(spec)
    assert parsed.gait.family == "free" and parsed.evidence.random_search and parsed.search.seed == 0


def test_infeasible_share_is_over_every_generation():
    assert ex.infeasible_share([{"f": 0.25}, {"f": 0.5}, {"f": None}], "f") == pytest.approx(0.625)
    assert ex.infeasible_share([], "f") is None


def test_the_section_when_the_data_agrees_with_the_earlier_record():
    md = ex.render_free([ledger(result(2.0, 1.5, 1.8, [0.25, 0.5], [0.25, 0.25]))])
    assert '"search": {"population": 16, "generations": 5, "seed": 0}' in md
    assert "96 evaluations" in md and "300 s wall" in md
    assert "| GA's best | 2.0000 | 1.800 | yes | T 0.812 s, duty 0.50 / 0.61 / 0.55 / 0.70 | 62% |" in md
    assert "| random search, same budget | 1.5000 | 0.900 | yes | - | 75% |" in md
    assert "| Table 1's trot (T = 0.46 s) | 1.1000 | 1.031 | yes | - | - |" in md
    assert "walks 10 periods no" in md
    assert md.count("agrees") == 3 and "contradicted" not in md


def test_the_section_says_plainly_where_the_data_contradicts_it():
    md = ex.render_free([ledger(result(0.9, 1.5, 0.6, [0.75, 0.9], [0.8, 0.6]))])
    assert md.count("**contradicted**, the record is wrong for this run") == 3 and "agrees" not in md
    assert "(CoT final 0.600 against 1.031)" in md and "(J 1.5000 against the GA's 0.9000)" in md
    assert ex.render_free([None]).startswith("*No data yet")


def test_the_experiment_appends_and_skips(tmp_path, monkeypatch):
    calls: list[dict] = []
    monkeypatch.setattr(ex, "_job", lambda data: calls.append(data) or result(2.0, 1.5, 1.8, [0.5], [0.5]))
    p = ex.FreeParams(json_out=tmp_path / "free.json")
    logs: list[str] = []
    md = ex._free(p, logs.append)
    data = json.loads((tmp_path / "free.json").read_text())
    assert len(data["runs"]) == 1 and data["runs"][0]["spec"] == ex.free_spec(p) and md == ex.render_free([data])
    ex._free(p, logs.append)
    assert len(calls) == 1 and any("skipped" in m for m in logs)

"""The staircase section of docs/multigait.md from its ledger (issue 28): the best tree's
heights and distance to the goal, the search's measured steps per generation and rate, and
the paper-size estimate computed from them (a small hand-made result here, no simulation)."""

from __future__ import annotations

import json

import pytest

from app.jobs.multigait.reproduce import stairs as st
from app.jobs.multigait.spec import MultigaitSpec


def result() -> dict:
    nodes = [{"x": 6.0, "y": 13.5, "z": 0.5, "ground": 0.0}, {"x": 9.0, "y": 13.0, "z": 0.52, "ground": 0.0},
             {"x": 10.5, "y": 13.2, "z": 1.1, "ground": 0.6}]
    return {"robot": "quadropod", "gaits": 2, "iterations": 8, "paper_iterations": 150,
            "result": {"goal_distance_mu": 19.84}, "nodes": nodes, "steps": [0.6, 1.2, 1.8, 2.4, 3.0],
            "goal": [30.0, 13.5, 3.5],
            "search": {"generations_run": 3, "evaluations": 12, "sim_steps": 3_000_000, "wall_s": 100.0},
            "controls": [], "timing": {"sim_steps": 7_400_000, "analysis_s": 150.0}}


def ledger() -> dict:
    spec = st.stairs_spec(st.StairsParams())
    return {"schema": 1, "experiment": "multigait-stairs", "command": st.STAIRS_COMMAND,
            "params": st.StairsParams().model_dump(mode="json"), "code_version": "v", "planned": 1,
            "runs": [{"name": "s", "key": "k", "spec": spec, "seed": 0, "code_version": "v", "wall_s": 250.4,
                      "cpu_s": 180.0, "result": result()}], "superseded": []}


def test_the_spec_is_issue_12s_small_staircase_run():
    spec = st.stairs_spec(st.StairsParams())
    assert spec == {"kind": "multigait", "robot": "quadropod", "map": "stairs", "cost": "distance",
                    "search": {"particles": 4, "generations": 2, "seed": 0}, "planner": {"iterations": 8}}
    assert MultigaitSpec.parse(spec).k == 2 and MultigaitSpec.parse(spec | {"planner": {}}).iterations == 150


def test_the_paper_size_estimate_scales_the_measured_run():
    e = st.paper_estimate(result(), particles=20, generations=150)
    assert e["steps_per_generation"] == pytest.approx(1e6) and e["steps_per_s"] == pytest.approx(3e4)
    assert e["paper_steps_per_generation"] == pytest.approx(1e6 * 20 / 4 * 150 / 8)
    assert e["search_h"] == pytest.approx(93.75e6 * 151 / 3e4 / 3600) and e["job_h"] == pytest.approx(2 * e["search_h"])
    # twice the measured rate halves the estimate: it is computed, not typed
    faster = result()
    faster["search"]["wall_s"] = 50.0
    assert st.paper_estimate(faster, 20, 150)["search_h"] == pytest.approx(e["search_h"] / 2)


def test_the_section_states_heights_distance_cost_and_the_estimate():
    md = st.render_stairs([ledger()])
    assert '"map": "stairs"' in md and "Quadropod, k = 2 gaits, K = 8; 5 steps of 0.6 mu up to a plateau at 3 mu" in md
    assert "3 nodes, 1 of them over a step; its highest node is at z = 1.10 mu over ground at 0.6 mu" in md
    assert "ends 19.8 mu from the goal" in md
    assert "1.00 M steps per generation (3 generations, 100 s, 30.0k steps/s)" in md
    assert "took 250 s wall, 180 s CPU, 7.4 M steps" in md
    assert ("an estimate, not a measurement: 93.8 M steps per generation at 20 particles and K = 150 (this run's 1.00 M "
            "scaled linearly by particles and K), 150 + 1 generations at this run's 30.0k steps/s: about 131 h for the "
            "search, 262 h with its equal-budget random search") in md
    assert "the job averaged 0.72 cores of CPU" in md
    # issue 12's record set against the data: what matches, what does not
    assert ("highest node the same, distance to the goal the same, steps per paper-size generation **different**; "
            "the job took 3.2x the recorded wall time") in md and "took 150 s of it" in md
    assert "the paper-size estimate is 4.4x the recorded ~30 h" in md
    assert st.render_stairs([None]).startswith("*No data yet")


def test_the_experiment_appends_and_skips(tmp_path, monkeypatch):
    calls: list[dict] = []
    monkeypatch.setattr(st, "_stairs_job", lambda data: calls.append(data) or result())
    p = st.StairsParams(json_out=tmp_path / "stairs.json")
    logs: list[str] = []
    md = st.stairs(p, logs.append)
    data = json.loads((tmp_path / "stairs.json").read_text())
    assert len(data["runs"]) == 1 and md == st.render_stairs([data])
    st.stairs(p, logs.append)
    assert len(calls) == 1 and any("skipped" in m for m in logs)

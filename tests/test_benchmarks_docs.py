"""`gaitmend reproduce bench` and the sections it feeds (issue 28): each kind's bench figures
come from docs/benchmarks.json with the machine, the load, the commit and the date, the
target and verdict its bench reports, and the latest run of each kind; a kind already in
the file is not measured again unless asked. Rendered from a small fixture here, and the
real pages checked against a changed file. The same for `--kinds studies`, a study's dispatch
overhead (`gaitmend bench --studies --json`) with the deployment it ran on; its run through
a real worker is tests/studies/test_bench_cli.py's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.cli.bench import BenchParams, reproduce_bench
from app.cli.study_bench import deployment, where
from app.core.settings import load_settings
from app.jobs.registry import KINDS
from app.results import benchmarks, docs_gen

ROOT = Path(__file__).resolve().parents[1]


def _run(kind: str, figures: dict, load=(3.25, 4.5), date="2026-12-03 14:00 UTC", commit="0123456789abcdef") -> dict:
    return {"kind": kind, "figures": {kind: figures}, "machine": {"cpu": "Test CPU", "cores": 2, "python": "3.11"},
            "load_before": load[0], "load_after": load[1], "nice": 10, "commit": commit, "date": date,
            "wall_s": 12.3, "cpu_s": 10.0}


FIXTURE = {"schema": 1, "experiment": "bench", "command": benchmarks.COMMAND, "runs": [
    _run("tipping", {"step_ms": 9.99, "targets": {"step_ms_max": 1.0, "step_met": False}}, load=(9.0, 9.5),
         date="2026-12-01 10:00 UTC"),
    _run("tipping", {"step_ms": 0.4321, "step_cpu_ms": 0.25, "steps": 500, "constrained": True,
                     "targets": {"step_ms_max": 1.0, "step_met": True}}),
    _run("energy", {"fitness_eval_s": 0.61, "ga_wall_s": 87.0, "parts_s": {"qp": 0.0123}, "runs": [1, 2],
                    "targets": {"fitness_eval_s_max": 0.5, "ga_wall_s_max": 300.0, "fitness_eval_met": False,
                                "ga_met": True, "ratio_min": 0.9, "ratio_met": True}},
         commit="fedcba9876543210+dirty"),
]}


def test_a_kind_section_shows_its_latest_run_with_targets_load_and_provenance():
    text = benchmarks.render_kind("tipping", FIXTURE)
    assert "| `tipping.step_ms` | 0.432 ms | <= 1 ms | met |" in text
    assert "| `tipping.step_cpu_ms` | 0.25 ms | - | - |" in text  # no target: none shown
    assert "| `tipping.steps` | 500 | - | - |" in text and "| `tipping.constrained` | yes | - | - |" in text
    assert "9.99" not in text  # the earlier run is kept in the file, not shown
    assert "1 earlier run(s)" in text
    assert ("finished 2026-12-03 14:00 UTC, commit 0123456789, Test CPU, 2 cores, nice 10; 1-minute load average 3.2 "
            "before and 4.5 after") in text


def test_verdicts_pair_each_bound_with_the_longest_stem_and_nested_figures_keep_their_unit():
    text = benchmarks.render_kind("energy", FIXTURE)
    assert "| `energy.fitness_eval_s` | 0.61 s | <= 0.5 s | **not met** |" in text
    assert "| `energy.ga_wall_s` | 87.0 s | <= 300 s | met |" in text
    assert "| `energy.parts_s.qp` | 0.0123 s | - | - |" in text
    assert "runs" not in text.split("\n\n")[0]  # lists stay in the JSON
    assert "(with uncommitted changes)" in text
    assert benchmarks.verdicts(FIXTURE["runs"][2]["figures"]["energy"])["ratio"] == (">= 0.9", True)
    assert benchmarks.unit_of("rollout_s_per_generation") == "s per generation"
    assert benchmarks.unit_of("steps") == "" and benchmarks.unit_of("sim_steps_per_s") == "/s"


def test_the_summary_shows_every_kind_top_level_figures_with_their_load():
    text = benchmarks.render_all(FIXTURE)
    assert "| tipping | `tipping.step_ms` | 0.432 ms | <= 1 ms | met | 3.2 / 4.5 |" in text
    assert "| energy | `energy.fitness_eval_s` | 0.61 s | <= 0.5 s | **not met** | 3.2 / 4.5 |" in text
    assert "parts_s" not in text  # nested figures: the kind's own section
    missing = [k for k, kind in KINDS.items() if kind.bench() and k not in ("tipping", "energy")]
    for k in missing:
        assert f"{k}: not measured yet (`gaitmend reproduce bench --kinds {k} --write-docs`)" in text
    assert "No data yet" in benchmarks.render_all(None) and "No data yet" in benchmarks.render_kind("tipping", None)


def _fake_bench(calls: list):
    def bench(quick, log, kinds):
        calls.append((quick, list(kinds)))
        return {"cores": 2, "quick": quick, kinds[0]: {"x_ms": float(len(calls))}}
    return bench


def test_reproduce_appends_each_kind_and_skips_those_already_there(tmp_path):
    path = tmp_path / "benchmarks.json"
    have = [k for k, kind in KINDS.items() if kind.bench()]
    path.write_text(json.dumps({**FIXTURE, "runs": [_run(k, {"x_ms": 0.5}) for k in have[1:]]}))
    calls: list = []
    out = reproduce_bench(BenchParams(json_out=path), lambda m: None, _fake_bench(calls))
    assert calls == [(False, [have[0]])]  # only the kind the file lacked, at the full budget
    row = json.loads(path.read_text())["runs"][-1]
    assert row["kind"] == have[0] and row["figures"] == {have[0]: {"x_ms": 1.0}}  # cores/quick are not figures
    assert {"machine", "load_before", "load_after", "commit", "date", "nice", "wall_s"} <= row.keys()
    assert row["machine"]["cores"] >= 1 and row["machine"]["cpu"]
    assert f"`{have[0]}.x_ms`" in out
    reproduce_bench(BenchParams(json_out=path), lambda m: None, _fake_bench(calls))
    assert len(calls) == 1  # nothing left to measure
    reproduce_bench(BenchParams(kinds=have[1], json_out=path), lambda m: None, _fake_bench(calls))
    runs = json.loads(path.read_text())["runs"]
    assert calls[-1] == (False, [have[1]]) and [r["kind"] for r in runs].count(have[1]) == 2  # kept beside the old
    assert "2.00 ms" in benchmarks.render_kind(have[1], {"runs": runs})  # the new run is the one shown


def test_an_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="no kind with a bench named nope"):
        BenchParams(kinds="tipping,nope")


def test_the_pages_follow_the_committed_file(docs_copy):
    tmp_path = docs_copy
    assert docs_gen.check(tmp_path) == []
    path = tmp_path / "docs" / "benchmarks.json"
    data = json.loads(path.read_text())
    kinds = {r["kind"] for r in data["runs"]}
    assert {k for k, kind in KINDS.items() if kind.bench()} <= kinds  # every kind is measured in the committed file
    tipping = [r for r in data["runs"] if r["kind"] == "tipping"][-1]
    tipping["figures"]["tipping"]["tipping_step_ms"] = 123.0
    path.write_text(json.dumps(data))
    diffs = docs_gen.check(tmp_path)
    assert sorted(d.split("\n")[0] for d in diffs) == ["--- docs/benchmarks.md (as written)",
                                                        "--- docs/tipping.md (as written)"]
    assert all("123 ms" in d for d in diffs)
    studies = [r for r in data["runs"] if r["kind"] == "studies"]
    assert studies, "the committed file holds no study dispatch run (gaitmend reproduce bench --kinds studies)"
    studies[-1]["figures"]["study_dispatch"]["overhead_per_point_ms"] = 123.0
    path.write_text(json.dumps(data))
    diffs = docs_gen.check(tmp_path)
    study_diff = [d for d in diffs if d.startswith("--- docs/studies.md")]
    assert len(diffs) == 3 and len(study_diff) == 1 and "**123.0 ms**" in study_diff[0]


def _study_run(overhead_ms: float, met: bool, date: str, load=(4.56, 5.04), commit="0123456789abcdef") -> dict:
    figures = {"points": 200, "status": "succeeded", "wall_s": 61.23, "jobs_claim_to_finish_s": 57.2,
               "kind_compute_s": 20.05, "overhead_per_point_ms": overhead_ms, "overhead_vs_kind_compute_ms": 205.9,
               "target_ms": 50.0, "met": met}
    return {**_run("studies", {}, load=load, date=date, commit=commit), "figures": {"study_dispatch": figures},
            "deployment": {"broker": "redis://127.0.0.1:6379", "database": "postgresql://127.0.0.1:5432"}}


STUDY_FIXTURE = {**FIXTURE, "runs": [*FIXTURE["runs"], _study_run(99.9, False, "2026-12-01 09:00 UTC"),
                                     _study_run(20.15, True, "2026-12-03 17:40 UTC", commit="fedcba9876543210+dirty")]}


def test_the_study_dispatch_section_shows_the_latest_run_with_its_deployment_and_load():
    assert benchmarks.render_studies(STUDY_FIXTURE) == (
        "| figure | measured |\n|---|---|\n"
        "| overhead per point, beside the jobs' own work (claim -> finish) | **20.1 ms** (target <= 50 ms: met) |\n"
        "| overhead per point, beside the kinds' compute alone | 205.9 ms |\n"
        "| wall, from the POST until the study finished | 61.23 s |\n"
        "| jobs' claim -> finish (sum) | 57.20 s |\n"
        "| kinds' compute (sum) | 20.05 s |\n"
        "| points | 200 (succeeded) |\n"
        "| deployment | broker redis://127.0.0.1:6379, database postgresql://127.0.0.1:5432 |\n"
        "| 1-minute load average before / after | 4.6 / 5.0 |\n"
        "| machine | Test CPU, 2 cores, nice 10 |\n"
        "| commit | fedcba9876 (uncommitted changes) |\n"
        "| finished | 2026-12-03 17:40 UTC |\n"
        "\n`gaitmend bench --studies --json` as `gaitmend reproduce bench --kinds studies --write-docs` ran it; "
        "1 earlier run kept in [benchmarks.json](benchmarks.json), not shown.\n")
    only_old = {"runs": STUDY_FIXTURE["runs"][-2:-1]}
    assert "**99.9 ms** (target <= 50 ms: **not met**)" in benchmarks.render_studies(only_old)
    assert benchmarks.render_studies(only_old).endswith("0 earlier runs kept in [benchmarks.json](benchmarks.json), "
                                                         "not shown.\n")
    expected = ("*No data yet: `gaitmend reproduce bench --kinds studies --write-docs` writes "
                "docs/benchmarks.json.*\n")
    assert benchmarks.render_studies(FIXTURE) == expected and benchmarks.render_studies(None) == expected
    assert "studies" not in benchmarks.render_all(STUDY_FIXTURE)  # not a kind: the summary lists the kinds


def test_a_deployment_is_recorded_without_credentials():
    assert where("postgresql://postgres:secret@127.0.0.1:5432/test?options=-csearch_path%3Dx") == \
        "postgresql://127.0.0.1:5432"
    assert where("redis://:pw@redis.example/0") == "redis://redis.example"
    assert deployment(load_settings(data_dir="/nonexistent")) == {"broker": "embedded (filesystem)",
                                                                  "database": "embedded (SQLite)"}
    served = load_settings(broker_url="rediss://u:p@10.0.0.2:6380/1", database_url="postgresql+psycopg://u:p@db/x",
                           database_password="secret")
    assert deployment(served) == {"broker": "rediss://10.0.0.2:6380", "database": "postgresql+psycopg://db"}


def test_reproduce_studies_appends_a_row_only_when_named(tmp_path):
    path = tmp_path / "benchmarks.json"
    calls: list = []

    def studies(points, log):
        calls.append(points)
        return {"study_dispatch": STUDY_FIXTURE["runs"][-1]["figures"]["study_dispatch"] | {"points": points},
                "deployment": {"broker": "b", "database": "d"}}

    out = reproduce_bench(BenchParams(kinds="studies", study_points=7, json_out=path), lambda m: None,
                          _fake_bench(calls), studies)
    assert calls == [7]  # no kind's bench ran
    row = json.loads(path.read_text())["runs"][-1]
    assert row["kind"] == "studies" and row["deployment"] == {"broker": "b", "database": "d"}
    assert row["figures"]["study_dispatch"]["points"] == 7
    assert {"machine", "load_before", "load_after", "commit", "date", "nice", "wall_s", "cpu_s"} <= row.keys()
    assert out.startswith("| figure | measured |") and "| points | 7 (succeeded) |" in out
    reproduce_bench(BenchParams(json_out=path), lambda m: None, _fake_bench(calls), studies)
    assert 7 in calls and calls.count(7) == 1 and len(calls) > 1  # the default: the kinds, never the study


def test_study_points_need_the_studies_bench():
    assert BenchParams(kinds="tipping,studies", study_points=6).study_points == 6
    with pytest.raises(ValueError, match="6 points: only --kinds studies runs a study"):
        BenchParams(kinds="tipping", study_points=6)
    with pytest.raises(ValueError, match="or studies: a study's dispatch overhead"):
        BenchParams(kinds="studies,nope")


def test_a_run_names_its_host_by_cpu_family_and_model_where_the_machine_says():
    from pathlib import Path

    from app.core.host import machine, machine_text

    m = machine()
    info = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    if "cpu family" in info:  # x86 Linux: two hosts sold as "AMD EPYC" differ by family
        assert isinstance(m["cpu_family"], int) and isinstance(m["cpu_model"], int)
        assert machine_text(m).startswith(f"{m['cpu']}, family {m['cpu_family']} model {m['cpu_model']}, ")
    assert machine_text({"cpu": "AMD EPYC", "cpu_family": 26, "cpu_model": 2, "cores": 2}) == \
        "AMD EPYC, family 26 model 2, 2 cores"
    assert machine_text({"cpu": "AMD EPYC", "cores": 2}) == "AMD EPYC, 2 cores"  # runs recorded before


def test_the_adapt_section_shows_the_latest_run_with_both_verdicts():
    def row(warm, cold, date):
        r = _run("adapt", {}, date=date)
        r["figures"] = {"adapt_proposal": {"elites": 10000, "trials": 20, "warm_s": warm, "warm_median_s": warm + 0.01,
                                           "cold_s": cold, "target_s": 1.0, "met": warm <= 1.0, "met_cold": cold <= 1.0,
                                           "repeats": 3}}
        return r

    data = {"schema": 1, "experiment": "bench", "command": benchmarks.COMMAND,
            "runs": [row(2.5, 3.0, "2026-12-01 10:00 UTC"), row(0.2, 1.4, "2026-12-03 14:00 UTC")]}
    text = benchmarks.render_adapt(data)
    assert "over a map of 10,000 elites" in text and "took 0.20 s (best of 3; median 0.21 s)" in text
    assert "warm met, after a restart **not met**" in text and "2026-12-03 14:00 UTC" in text
    assert "gaitmend reproduce bench --kinds adapt --write-docs" in benchmarks.render_adapt(None)
    with pytest.raises(ValueError):
        BenchParams(kinds="adapts")
    assert BenchParams(kinds="adapt").kinds == "adapt"

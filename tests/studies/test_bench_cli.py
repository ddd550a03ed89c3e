"""`gaitmend bench --studies --quick`: a study's dispatch overhead measured through a real
worker on the embedded deployment (SQLite, filesystem broker), as a user runs it; and
`gaitmend reproduce bench --kinds studies`, which runs the same bench and appends it to a
benchmarks file with the deployment it ran on, as docs/studies.md's section reads it. Only the
figures' presence and consistency are checked: targets live in the benchmark, not here."""

from __future__ import annotations

import json
import subprocess
import sys

from service_support import ENTRY, deployment, proc_env

from app.results import benchmarks


def _gaitmend(tmp_path, *args: str) -> subprocess.CompletedProcess:
    p = subprocess.run([sys.executable, "-c", ENTRY, *args], env=proc_env(deployment(tmp_path)), capture_output=True,
                       text=True, timeout=600, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-3000:]
    return p


def _consistent(f: dict, points: int) -> None:
    assert f["points"] == points and f["status"] == "succeeded"
    assert 0 < f["kind_compute_s"] < f["jobs_claim_to_finish_s"] < f["wall_s"]
    # wall_s and jobs_claim_to_finish_s are printed to 0.01 s (each off by up to 0.005 s) and the
    # overhead to 0.1 ms from the unrounded times: recomputed from the printed ones it may differ
    # by up to 1000 * 0.01 / points + 0.05 ms
    recomputed = 1000 * (f["wall_s"] - f["jobs_claim_to_finish_s"]) / points
    assert abs(f["overhead_per_point_ms"] - recomputed) <= 1000 * 0.01 / points + 0.05 + 1e-9
    assert f["target_ms"] == 50.0 and isinstance(f["met"], bool)


EMBEDDED = {"broker": "embedded (filesystem)", "database": "embedded (SQLite)"}


def test_bench_studies_quick_reports_the_dispatch_figures(tmp_path):
    out = json.loads(_gaitmend(tmp_path, "bench", "--studies", "--quick", "--json").stdout.strip().splitlines()[-1])
    _consistent(out["study_dispatch"], 6)
    assert out["deployment"] == EMBEDDED


def test_reproduce_bench_studies_appends_the_run_the_section_shows(tmp_path):
    path = tmp_path / "benchmarks.json"
    _gaitmend(tmp_path, "reproduce", "bench", "--kinds", "studies", "--study-points", "4", "--json-out", str(path))
    runs = json.loads(path.read_text())["runs"]
    assert [r["kind"] for r in runs] == ["studies"]  # the study alone: no kind's bench ran
    _consistent(runs[0]["figures"]["study_dispatch"], 4)
    assert runs[0]["deployment"] == EMBEDDED
    text = benchmarks.render_studies({"runs": runs})
    assert "| points | 4 (succeeded) |" in text
    assert "| deployment | broker embedded (filesystem), database embedded (SQLite) |" in text
    assert f"| finished | {runs[0]['date']} |" in text and "0 earlier runs" in text

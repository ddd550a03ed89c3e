"""A study's scaling over workers as data (app/cli/study_scaling.py --json-out, rendered by
app/results/scaling.py): a real two-point study run serially and then served by two real
workers on the embedded broker, appended to a ledger; the page's table and the atlas
estimate follow from the file."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest

from app.results import scaling

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STUDY = {"name": "two points", "base": {"kind": "recovery", "robot": "jethexa",
                                        "search": {"population": 4, "generations": 1}, "sim": {"duration_s": 1.0},
                                        "controls": {"random_search": False}},
         "grid": {"damage.lost_legs": [[1, 6], [4]]},
         "report": {"group_by": ["damage.lost_legs"], "metrics": ["best.fitness"]}}


@pytest.mark.slow
def test_a_measurement_is_appended_with_its_provenance(tmp_path):
    (tmp_path / "study.json").write_text(json.dumps(STUDY))
    out = tmp_path / "scaling.json"
    earlier = {"schema": 1, "experiment": "study-scaling", "command": "earlier", "runs": [_run(800.0, 470.0, 920.0)]}
    out.write_text(json.dumps(earlier))  # a ledger with a run already in it
    env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")} | {
        "GAITMEND_DATA_DIR": str(tmp_path / "data"), "PYTHONPATH": ROOT}
    r = subprocess.run([sys.executable, "-m", "app.cli.study_scaling", str(tmp_path / "study.json"), "--workers",
                        "2", "--out", str(tmp_path / "run"), "--json-out", str(out)], env=env, cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    data = json.loads(out.read_text())
    assert data["experiment"] == "study-scaling" and len(data["runs"]) == 2  # appended, not replaced
    assert data["runs"][0] == earlier["runs"][0]
    run = data["runs"][-1]
    assert run["points"] == 2 and run["served_status"] == "succeeded" and run["same_aggregate"] is True
    assert run["bundles"] == 2 and run["bundle_bytes_median"] > 100_000
    # the ratio is of the unrounded times; both are written to 0.1 s
    assert run["ratio"] == pytest.approx(run["served_s"] / run["serial_s"], abs=0.1 / run["serial_s"] + 1e-3)
    assert run["machine"]["cores"] >= 1 and run["date"].endswith("UTC") and "load_before" in run
    text = scaling.render_table(data)
    assert f"{run['serial_s']:.1f} s" in text and f"**{run['ratio']:.3f}**" in text and "identical" in text


def test_bad_worker_counts_are_refused(tmp_path):
    r = subprocess.run([sys.executable, "-m", "app.cli.study_scaling", "recovery_table2", "--workers", "0"],
                       env=os.environ | {"PYTHONPATH": ROOT}, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--workers must be 1..64" in r.stderr


def _run(serial, served, claim, ratio=None, cores=2):
    return {"study": "s", "points": 40, "base": {}, "workers": 2, "cores": cores, "serial_s": serial,
            "served_s": served, "ratio": ratio if ratio is not None else round(served / serial, 3),
            "served_status": "succeeded", "served_jobs_claim_to_finish_s": claim, "same_aggregate": True,
            "bundles": 40, "bundle_bytes_median": 5_300_000, "broker": "127.0.0.1:6379", "database": "127.0.0.1:5432",
            "machine": {"cpu": "X", "cores": cores}, "load_before": 0.1, "load_after": 1.9, "nice": 0, "commit": "abc",
            "date": "2026-12-03 20:00 UTC", "wall_s": 1300.0}


def test_the_table_states_the_target_and_the_contention():
    met = scaling.render_table({"runs": [_run(800.0, 470.0, 920.0)]})
    assert "**0.588** (target <= 0.6: met)" in met and "15 % longer served than alone" in met
    assert "5.3 MB each" in met and "20.0 s a point serially" in met
    later = scaling.render_table({"runs": [_run(800.0, 470.0, 920.0), _run(700.0, 450.0, 760.0)]})
    assert "(target <= 0.6: **not met**)" in later  # the latest run is shown
    assert "No data yet" in scaling.render_table({"runs": []})


def test_the_atlas_estimate_is_rounds_times_the_atlas_point_cost():
    atlas = {"params": {"seeds": 2}, "runs": [{"spec": {"damage": {"lost_legs": [d]}}, "cpu_s": c}
                                              for d, c in [(2, 200.0), (3, 240.0), (5, 300.0)]]}
    table2 = [{"lost_legs": [1, 6]}, {"lost_legs": [1, 6]}]
    text = scaling.render_estimate([{"runs": [_run(800.0, 470.0, 880.0)]}, atlas, table2])
    points, k, point = 4 * 2, 880.0 / 800.0, 240.0  # four losses x 2 seeds; median CPU per point
    assert f"= {points} points" in text
    assert f"| 1 | 4 | {math.ceil(points / 2) * point * k / 60:.0f} min |" in text
    assert f"| 2 | 2 | {2 * point * k / 60:.0f} min |" in text
    assert f"| >= 4 | 1 | {300.0 * k / 60:.0f} min (the slowest point) |" in text


@pytest.mark.parametrize("url, want", [
    (None, "embedded"), ("redis://127.0.0.1:6379/0", "redis (127.0.0.1:6379)"),
    ("postgresql://postgres:secret@127.0.0.1:5432/test?options=-csearch_path%3Dx", "postgresql (127.0.0.1:5432)"),
    ("postgresql+psycopg://u:p@db/x", "postgresql (db)"), ("sqlite:////tmp/x.db", "sqlite"),
])
def test_the_deployment_is_recorded_by_scheme_and_host_only(url, want):
    from app.cli.study_scaling import where

    assert where(url, "embedded") == want

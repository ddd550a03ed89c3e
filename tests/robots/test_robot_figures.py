"""docs/robots.md's "Measured" table as data: scripts/robot_figures.py measures the robot
layer for real (third-party uploads, the CLI, the batched IK, mj_step) and appends a run to
its ledger; app/results/robot_figures.py renders the latest."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from app.results import robot_figures

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_script_appends_a_run_that_the_page_renders(tmp_path):
    out = tmp_path / "robot_figures.json"
    env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")}
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "robot_figures.py"), "--json-out", str(out)], env=env,
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    data = json.loads(out.read_text())
    assert data["experiment"] == "robot-figures" and len(data["runs"]) == 1
    f = data["runs"][0]["figures"]
    for key, _ in robot_figures.ROWS:
        assert len(f[key]) == 3 and all(0 < t < 300 for t in f[key]), (key, f[key])
    assert f["ik_jethexa_30x600_iterations"] >= 1
    assert set(f["mj_step_per_s"]) == {"jethexa", "gymnasium ant", "dm_control quadruped"}
    assert all(v > 100 for v in f["mj_step_per_s"].values())
    text = robot_figures.render(data)
    assert f"{min(f['prepare_ant_s']):.2f} s" in text and "0 earlier runs kept" in text
    assert list(tmp_path.iterdir()) == [out]  # nothing else left behind


def test_no_data_says_which_command_writes_it():
    assert robot_figures.COMMAND in robot_figures.render(None)

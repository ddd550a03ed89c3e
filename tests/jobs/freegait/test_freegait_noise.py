"""freegait under localisation and zone-position errors (issue 28): the exact walk is
untouched by the option, an error moves what the planner believes (and so where the feet
land against the true zones), and the experiment is resumable through its ledger."""

from __future__ import annotations

import json

import numpy as np

from app.jobs.freegait.reproduce.experiments import NoiseParams, _world, noise, render_noise
from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.walk import WalkConfig, walk


def _short(**kw):
    ter, fld = _world(0.3 + 2.5, 3.0, 0.04, 1000, 8.0, 2000)
    return walk(ter, fld, WalkConfig(route=Route(distance=0.3), seed=0, **kw))


def test_zero_error_is_the_exact_walk_and_an_error_moves_the_footholds():
    exact, zero = _short(), _short(position_error_m=0.0, zone_error_m=0.0)
    assert np.array_equal(exact.steps["qpos"], zero.steps["qpos"])
    off = _short(position_error_m=0.05, zone_error_m=0.05)
    a, b = exact.summary(), off.summary()
    # the planner believes the body 5 cm (sigma) away: its planned footholds (in its own
    # world frame) no longer match where the feet land
    assert b["foothold_error_max_m"] > a["foothold_error_max_m"] + 0.01
    assert not np.array_equal(exact.steps["qpos"], off.steps["qpos"])


def test_the_noise_experiment_resumes_and_renders(tmp_path):
    p = NoiseParams(fields=1, arms="exact,dgps_x4", distance_m=0.3, json_out=tmp_path / "noise.json")
    logs: list[str] = []
    md = noise(p, logs.append)
    data = json.loads((tmp_path / "noise.json").read_text())
    assert [r["name"] for r in data["runs"]] == ["exact field 0", "dgps_x4 field 0"]
    assert data["runs"][1]["result"]["sigma_m"] == 0.04 and data["planned"] == 2
    assert "| exact | 0.00 |" in md and "| dgps_x4 | 0.04 |" in md
    # a kill after the first run: the second call computes only the missing run
    data["runs"] = data["runs"][:1]
    (tmp_path / "noise.json").write_text(json.dumps(data))
    logs.clear()
    noise(p, logs.append)
    assert sum("skipped" in m for m in logs) == 1 and sum("done in" in m for m in logs) == 1
    assert render_noise([json.loads((tmp_path / "noise.json").read_text())]) == md

"""The repertoire job: the same seed gives the same map; a run killed after any checkpoint
resumes to the same map bit for bit; cancel stops between iterations; the random control
runs at the same budget; the bundle's archive.csv reads into a DataFrame of the map."""

from __future__ import annotations

import copy
import io
import json
import zipfile

import numpy as np
import pandas as pd
import pytest

from app.jobs.base import Cancelled, dumps
from app.jobs.registry import get_kind, parse_spec

KIND = get_kind("repertoire")
SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 5, "checkpoint_every": 1},
        "sim": {"duration_s": 0.3, "settle_s": 0.05, "timestep_s": 0.002}, "evidence": {"rescore_elites": 3}}


class Ctx:
    def __init__(self, ckpt=None, kill_at=None, cancel_at=None):
        self.artifact_dir, self.ckpt, self.saves, self.kill_at, self.cancel_at = None, ckpt, 0, kill_at, cancel_at
        self.progress_calls = 0

    def progress(self, done, total, info):
        self.progress_calls += 1

    def save_checkpoint(self, state):
        self.ckpt = json.loads(json.dumps(state))  # stored as JSON
        self.saves += 1
        if self.saves == self.kill_at:
            raise KeyboardInterrupt  # kill -9 right after the checkpoint is written

    def load_checkpoint(self):
        return copy.deepcopy(self.ckpt)

    def is_cancelled(self):
        return self.cancel_at is not None and self.progress_calls >= self.cancel_at

    def load_robot(self, robot_id):
        raise AssertionError("a built-in robot")


def _same(a, b) -> None:
    sa, sb = json.loads(dumps(a.summary)), json.loads(dumps(b.summary))
    sa.pop("timing"), sb.pop("timing")
    assert sa == sb
    assert a.history == b.history and a.evaluations == b.evaluations
    np.testing.assert_array_equal(a.traces["best"]["qpos"], b.traces["best"]["qpos"])


@pytest.fixture(scope="module")
def first():
    return KIND.run(parse_spec(SPEC), Ctx())


def test_the_same_seed_gives_the_same_map_and_another_seed_another(first):
    _same(first, KIND.run(parse_spec(SPEC), Ctx()))
    other = KIND.run(parse_spec({**SPEC, "seed": 6}), Ctx())
    assert other.summary["elites"]["solution"] != first.summary["elites"]["solution"]


@pytest.mark.parametrize("kill_at", [2, 3])
def test_a_run_killed_after_a_checkpoint_resumes_to_the_same_map(first, kill_at):
    ctx = Ctx(kill_at=kill_at)
    with pytest.raises(KeyboardInterrupt):
        KIND.run(parse_spec(SPEC), ctx)
    assert ctx.ckpt["iteration"] == kill_at
    _same(first, KIND.run(parse_spec(SPEC), Ctx(ckpt=ctx.ckpt)))


def test_cancel_stops_between_iterations():
    ctx = Ctx(cancel_at=2)
    with pytest.raises(Cancelled):
        KIND.run(parse_spec(SPEC), ctx)
    assert ctx.progress_calls == 2


def test_the_random_control_runs_at_the_same_budget_into_the_same_cells(first):
    s = first.summary
    spec = parse_spec(SPEC)
    (rnd,) = s["controls"]
    assert rnd["name"] == "random_search" and rnd["evaluations"] == s["search"]["evaluations"] == 4 * 5
    assert first.evaluations == spec.evaluations_budget == 2 * 20 + 3 + 1
    last = first.history[-1]
    assert (last["random_coverage"], last["random_qd_score"]) == (rnd["metrics"]["coverage"], rnd["metrics"]["qd_score"])
    assert [r["evaluations"] for r in first.history] == [5, 10, 15, 20]
    assert s["archive"]["coverage"] == s["archive"]["elites"] / 30 == last["coverage"]
    e = s["elites"]
    assert e["cell"] == sorted(e["cell"]) and len(e["cell"]) == s["archive"]["elites"]
    assert s["archive"]["qd_score"] == pytest.approx(sum(v + 1.0 for v in e["objective"]))
    assert all(0 <= c <= 1 for row in e["measures"] for c in row) and all(t == 0.002 for t in e["timestep_s"])
    check = s["timestep_check"]
    assert check["elites"] == 3 and check["half_timestep_s"] == 0.001


def test_the_bundle_holds_the_map_as_a_table(first, tmp_path):
    from app.results.bundle import write_bundle

    path = write_bundle(tmp_path / "b.zip", "job-1", parse_spec(SPEC), first)
    with zipfile.ZipFile(path) as z:
        table = pd.read_csv(io.BytesIO(z.read("archive.csv")))
        layout = json.loads(z.read("controller/layout.json"))
        source = z.read("controller/repertoire_controller.py").decode()
    e = first.summary["elites"]
    assert list(table["cell"]) == e["cell"] and len(table) == first.summary["archive"]["elites"]
    np.testing.assert_array_equal(table["forward_m"].to_numpy(), np.asarray(e["objective"]))
    np.testing.assert_array_equal(table[[f"x{i}" for i in range(55)]].to_numpy(), np.asarray(e["solution"]))
    # the shipped controller, run from its own file, gives the set-points the simulation used
    space: dict = {}
    exec(compile(source, "repertoire_controller.py", "exec"), space)
    shipped = space["Layout"].from_json(layout)
    x = np.asarray(first.summary["best"]["params"])
    ctrl = first.traces["best"]["ctrl"]
    t = first.traces["best"]["time_s"] - 0.002  # time_s is after each step; a set-point is applied during it
    np.testing.assert_array_equal(np.array([shipped.setpoints_single(x, ti) for ti in t[::20]]), ctrl[::20])

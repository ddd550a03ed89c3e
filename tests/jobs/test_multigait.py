"""Job kind ``multigait`` (paper 001): spec validation, a small real run, determinism and
resume, the staircase with simulated expansions, plots."""

import copy

import numpy as np
import pytest

from app.jobs.multigait import KIND as multigait
from app.jobs.base import Cancelled, SpecError
from app.jobs.registry import parse_spec

SMALL = {"kind": "multigait", "robot": "lizard", "search": {"particles": 6, "generations": 5, "seed": 3},
         "planner": {"iterations": 40}, "gait_duration_s": 8.0, "reuse": {"plans": 3, "iterations": 30},
         "verify": {"nodes": 12}}


class Ctx:
    def __init__(self, cancel_after=None, ckpt=None):
        self.artifact_dir = None
        self._ckpt = copy.deepcopy(ckpt)
        self.cancel_after = cancel_after
        self.calls = 0
        self.progress_rows = []

    def progress(self, done, total, info):
        self.progress_rows.append((done, total))

    def save_checkpoint(self, state):
        self._ckpt = copy.deepcopy(state)

    def load_checkpoint(self):
        return self._ckpt

    def is_cancelled(self):
        self.calls += 1
        return self.cancel_after is not None and self.calls > self.cancel_after


def test_defaults_are_the_papers():
    s = parse_spec({"kind": "multigait"})
    assert s.search.optimizer == "pso" and s.search.particles == 20 and s.search.generations == 150
    assert (s.search.w, s.search.phi1, s.search.phi2) == (0.1, 2.0, 2.0)
    assert s.k == 3 and s.iterations == 150 and s.gait_duration_s == 30.0
    assert parse_spec({"kind": "multigait", "cost": "distance"}).iterations == 100
    st = parse_spec({"kind": "multigait", "map": "stairs", "cost": "distance"})
    assert st.k == 2 and st.iterations == 150
    assert s.evaluations_budget == 3000


@pytest.mark.parametrize("bad,field", [
    ({"robot": "snake"}, "robot"),
    ({"map": "moon"}, "map"),
    ({"gaits": 0}, "gaits"),
    ({"search": {"particles": 1}}, "search.particles"),
    ({"search": {"optimizer": "de", "particles": 3}}, "particles"),
    ({"damage": {"stuck_modules": [1, 1]}}, "damage.stuck_modules"),
    ({"damage": {"stuck_modules": [7]}}, "damage.stuck_modules"),
    ({"cost": "speed"}, "cost"),
    ({"planner": {"iterations": 0}}, "planner.iterations"),
    ({"colour": "red"}, "colour"),
])
def test_bad_specs_name_the_field(bad, field):
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "multigait", **bad})
    assert field in str(e.value)


@pytest.fixture(scope="module")
def small_run():
    spec = parse_spec(SMALL)
    return spec, multigait.run(spec, Ctx())


def test_small_run_improves_on_its_first_generation(small_run):
    spec, res = small_run
    s = res.summary
    h = res.history
    assert len(h) == 5 and res.evaluations == 30
    assert s["result"]["final_best"] > h[0]["generation_best"] > 0
    assert s["result"]["reproduced"]  # the best gaits planned again give the recorded cost
    assert all(b2 >= b1 for b1, b2 in zip([r["best"] for r in h], [r["best"] for r in h][1:]))
    assert 0 < s["result"]["final_best"] <= 100
    assert s["timing"]["wall_s"] > 0 and "per_generation_s" in s["timing"]
    assert len(s["per_gait"]) == 3 and set(res.traces) >= {"gait1", "gait2", "gait3", "plan", "tree"}
    comp = s["composition"]
    assert comp["depth1_position_error_mu"] < 1e-6 and comp["nodes"] >= 1
    assert set(s["reuse"]) == {"empty_same", "column_same", "column_opposite"}
    tr = res.traces["gait1"]
    assert tr["qpos"].shape[0] == tr["time_s"].shape[0] == tr["com_m"].shape[0]


def test_same_seed_same_numbers_and_resume_is_bit_identical(small_run):
    spec, full = small_run
    ctx = Ctx(cancel_after=2)
    with pytest.raises(Cancelled):
        multigait.run(spec, ctx)
    assert len(ctx._ckpt["history"]) == 2
    resumed = multigait.run(spec, Ctx(ckpt=ctx._ckpt))
    assert resumed.history == full.history
    assert resumed.summary["best_params"] == full.summary["best_params"]
    assert resumed.summary["tree"] == full.summary["tree"]


def test_other_seed_other_gaits(small_run):
    spec, full = small_run
    other = parse_spec({**SMALL, "search": {**SMALL["search"], "seed": 4, "generations": 1},
                        "reuse": {"enabled": False}, "verify": {"nodes": 0}})
    res = multigait.run(other, Ctx())
    assert res.summary["best_params"]["values"] != full.summary["best_params"]["values"][: len(res.summary["best_params"]["values"])]


def test_damaged_robot_has_fewer_parameters():
    spec = parse_spec({**SMALL, "damage": {"stuck_modules": [3, 6]}, "search": {"particles": 3, "generations": 1},
                       "reuse": {"enabled": False}, "verify": {"nodes": 0}})
    res = multigait.run(spec, Ctx())
    assert len(res.summary["best_params"]["values"]) == 3 * 6 * 5
    assert 'name="hinge3"' not in res.model_xml and 'name="hinge4"' in res.model_xml


def test_staircase_expansions_are_simulated():
    spec = parse_spec({"kind": "multigait", "robot": "quadropod", "map": "stairs", "cost": "distance",
                       "search": {"particles": 2, "generations": 1}, "planner": {"iterations": 3},
                       "gait_duration_s": 2.0})
    res = multigait.run(spec, Ctx())
    s = res.summary
    assert s["gaits"] == 2 and s["composition"]["note"].startswith("expansions simulated")
    assert s["reuse"] is None
    pos = np.array(s["tree"]["pos_mu"])
    assert pos.shape[0] >= 1 and np.all(np.isfinite(pos))
    # the cost is the 3-D distance from the tree to the goal on the plateau
    goal = np.array(s["map"]["goal"])
    assert s["result"]["final_best"] == pytest.approx(np.linalg.norm(pos - goal, axis=1).min())


def test_plots(small_run, tmp_path):
    _, res = small_run
    files = multigait.figures(res, tmp_path)
    names = {p.name for p in files}
    for n in ("convergence", "gait_traces", "gait_distance_rotation", "tree_map", "composition_error", "reuse"):
        assert f"{n}.png" in names and f"{n}.svg" in names

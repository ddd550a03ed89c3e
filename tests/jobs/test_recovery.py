"""The recovery job end to end on the real simulator, at small budgets."""

import copy
import json

import pytest

from app.jobs.base import Cancelled, SpecError
from app.jobs.recovery.run import run, search_bounds
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.registry import parse_spec
from app.robots.catalog import JETHEXA

SMALL = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
         "search": {"population": 8, "generations": 4, "seed": 2}, "sim": {"duration_s": 3.0}}


class Ctx:
    def __init__(self, tmp_path, checkpoint=None, stop_after=None, cancel_after=None):
        self.artifact_dir = tmp_path
        self.checkpoints = []
        self._initial = checkpoint
        self.stop_after, self.cancel_after = stop_after, cancel_after
        self.progress_calls = []

    def progress(self, done, total, info):
        self.progress_calls.append((done, total, info))
        if self.stop_after is not None and done >= self.stop_after:
            raise KeyboardInterrupt  # a worker killed between two generations

    def save_checkpoint(self, state):
        self.checkpoints.append(json.loads(json.dumps(state)))

    def load_checkpoint(self):
        return self._initial

    def is_cancelled(self):
        return self.cancel_after is not None and len(self.checkpoints) >= self.cancel_after


def numbers(summary):
    s = copy.deepcopy(summary)
    s.pop("timing")
    return s


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    spec = parse_spec(SMALL)
    return spec, run(spec, Ctx(tmp_path_factory.mktemp("a")))


def test_small_run_beats_the_baseline(small_run):
    _, res = small_run
    s = res.summary
    assert s["best"]["fitness"] > s["baseline"]["fitness"]
    assert s["best"]["metrics"]["y_f_m"] > 0.1
    assert s["gait"]["name"] == "modified_pentagonal" and s["gait"]["sigma"] == 4
    assert set(s["best"]["params"]) == {"y0_leg2", "y0_leg3", "y0_leg4", "y0_leg5",
                                        "x0_leg2", "x0_leg3", "x0_leg4", "x0_leg5", "step_length", "step_height"}
    assert [h["generation"] for h in s["history"]] == list(range(5))
    bests = [h["best"] for h in s["history"]]
    assert bests == sorted(bests)  # DE's best never regresses
    assert all(h["worst"] <= h["mean"] <= h["best"] for h in s["history"])
    assert s["timing"]["evaluations"] == 8 * 5 + 2
    assert set(s["best"]["metrics"]) == {"x_f_m", "y_f_m", "yaw_f_deg", "roll_amp_deg", "pitch_amp_deg", "fell"}
    assert res.model_xml.startswith("<mujoco") and "leg1_coxa" not in res.model_xml


def test_same_seed_same_numbers(small_run, tmp_path):
    spec, res = small_run
    again = run(spec, Ctx(tmp_path))
    assert numbers(again.summary) == numbers(res.summary)


def test_resume_from_checkpoint_gives_the_uninterrupted_result(small_run, tmp_path):
    spec, res = small_run
    ctx = Ctx(tmp_path, stop_after=2)
    with pytest.raises(KeyboardInterrupt):
        run(spec, ctx)
    resumed = run(spec, Ctx(tmp_path, checkpoint=ctx.checkpoints[-1]))
    assert numbers(resumed.summary) == numbers(res.summary)


def test_cancel_is_seen_between_generations(tmp_path):
    ctx = Ctx(tmp_path, cancel_after=2)
    with pytest.raises(Cancelled):
        run(parse_spec(SMALL), ctx)
    assert len(ctx.checkpoints) == 2


def test_cmaes_option_runs(tmp_path):
    spec = parse_spec(SMALL | {"search": {"optimizer": "cmaes", "population": 8, "generations": 2, "seed": 0}})
    s = run(spec, Ctx(tmp_path)).summary
    assert len(s["history"]) == 3 and s["best"]["fitness"] >= s["history"][0]["generation_best"]


def test_neighbours_of_lost_legs_get_relaxed_y0_bounds():
    spec = RecoverySpec(damage={"lost_legs": [1]})
    lo, hi = search_bounds(spec, JETHEXA)
    # legs 2..6; neighbours of leg 1 are 2 (opposite) and 3 (same side)
    width = {2: 0.06, 3: 0.06, 4: 0.06, 5: 0.06, 6: 0.06}
    for i, leg in enumerate([2, 3, 4, 5, 6]):
        factor = 1.4 if leg in (2, 3) else 1.0
        assert hi[i] - lo[i] == pytest.approx(width[leg] * factor)
    assert list(lo[5:10]) == [0.09] * 5 and list(hi[-2:]) == [0.05, 0.05]


@pytest.mark.parametrize("patch,field", [
    ({"robot": "atlas"}, "robot"),
    ({"damage": {"lost_legs": [1, 3]}}, "damage.lost_legs"),
    ({"damage": {"lost_legs": [1, 1]}}, "damage.lost_legs"),
    ({"damage": {"lost_legs": [7]}}, "damage.lost_legs.0"),
    ({"bounds": {"x0_m": [0.13, 0.09]}}, "bounds"),
    ({"search": {"population": 3}}, "search.population"),
    ({"sim": {"duration_s": 0}}, "sim.duration_s"),
    ({"colour": "red"}, "colour"),
    ({"search": {"optimizer": "sgd"}}, "search.optimizer"),
    ({"kind": "dance"}, "kind"),
])
def test_bad_specs_name_the_field(patch, field):
    with pytest.raises(SpecError) as e:
        parse_spec(SMALL | patch)
    assert [x["field"] for x in e.value.errors][0] == field

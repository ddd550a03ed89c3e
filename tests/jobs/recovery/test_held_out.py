"""The held-out random models (issue 24) and the closed-loop job's report of the answer
both ways."""

import numpy as np
import pytest

from app.jobs.base import MemoryContext
from app.jobs.evidence import robustness_of
from app.jobs.recovery.cases import (HELD_OUT_STREAM, RANDOM_RANGES, SEARCH_STREAM, draw_models, random_models,
                                     random_world)
from app.jobs.recovery.run import run, sim_model
from app.jobs.recovery.spec import RecoverySpec
from app.robots.catalog import get_robot
from app.sim.perturb import same_signature

SMALL = {"kind": "recovery", "damage": {"lost_legs": [1, 6]}, "search": {"population": 4, "generations": 1, "seed": 5},
         "sim": {"duration_s": 3.0}, "controls": {"random_search": False},
         "robustness": {"cases": ["dt_half", "friction_0.7", "payload"], "held_out": 4}}


def test_draws_are_the_seeds_own_stream_inside_the_stated_ranges():
    a, b = draw_models(7, 30), draw_models(7, 30)
    assert a == b
    assert draw_models(8, 30) != a and draw_models(7, 30, SEARCH_STREAM) != a
    assert draw_models(7, 30, HELD_OUT_STREAM, generation=1) != a
    for k, (lo, hi) in RANDOM_RANGES.items():
        v = np.array([d[k] for d in a])
        assert np.all((v >= lo) & (v <= hi)) and v.std() > 0


def test_random_models_edit_what_their_draw_says_and_share_one_rollout():
    spec = RecoverySpec.parse(SMALL)
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    world = random_world(mspec)
    draws = draw_models(0, 3)
    models = random_models(mspec, draws, robot.geometry.total_mass)
    assert all(same_signature(models[0], m) for m in models)
    for d, m in zip(draws, models):
        np.testing.assert_allclose(m.actuator_forcerange, world.actuator_forcerange * d["motor_strength"])
        np.testing.assert_allclose(m.actuator_biasprm[:, 1], world.actuator_biasprm[:, 1] * d["servo_gain_scale"])
        np.testing.assert_allclose(m.geom_friction[:, 0], world.geom_friction[:, 0] * d["friction_scale"])
        assert m.body_mass.sum() == pytest.approx(world.body_mass.sum() * d["mass_scale"]
                                                  + d["payload_share"] * robot.geometry.total_mass)
        hf = m.hfield_size[0]
        assert hf[2] == pytest.approx(2 * d["floor_amplitude_m"])
    assert not np.array_equal(models[0].hfield_data, models[1].hfield_data)


@pytest.fixture(scope="module", params=["open_loop", "closed_loop"])
def small(request):
    spec = RecoverySpec.parse(SMALL | {"control": {"mode": request.param}})
    return spec, run(spec, MemoryContext())


def test_the_held_out_set_is_reported_apart_and_counted(small):
    spec, res = small
    s = res.summary
    rob = s["robustness"]
    held = rob["held_out"]
    assert held["n"] == 4 and len(held["models"]) == 4
    assert held["met"] == sum(m["target_met"] is True for m in held["models"])
    assert [m["draw"] for m in held["models"]] == draw_models(spec.seed, 4)
    assert rob["groups"]["numerics"]["total"] == 1 and rob["groups"]["physical"]["total"] == 2
    assert rob["groups"]["held_out"] == {"met": held["met"], "total": 4}
    assert robustness_of(s).total == 3  # the named cases only: the held-out set is apart
    # the budget counts the random-search best's re-scoring, which this spec switches off
    assert res.evaluations == spec.evaluations_budget - 1


def test_closed_loop_reports_the_answer_without_its_correction(small):
    spec, res = small
    c = res.summary["control"]
    if spec.control.mode == "open_loop":
        assert c == {"mode": "open_loop"}
        return
    assert c["law"]["yaw_gain"] == spec.control.yaw_gain
    ol = c["open_loop"]
    assert [x["name"] for x in ol["cases"]] == ["dt_half", "friction_0.7", "payload"]
    assert ol["held_out"]["n"] == 4
    assert ol["best"]["metrics"] != res.summary["best"]["metrics"]  # the correction acted


def test_the_page_shows_the_drive_and_the_held_out_share(small):
    from app.jobs.registry import get_kind

    spec, res = small
    kind = get_kind("recovery")
    rows = {r["label"]: r for r in kind.headline(res.summary)}
    held = res.summary["robustness"]["held_out"]
    assert rows["drive"]["value"] == spec.control.mode.replace("_", " ")
    assert rows["held-out random models meeting the target"]["value"] == 100 * held["share"]
    assert rows["timestep checks passed"]["value"] == "{met}/{total}".format(**res.summary["robustness"]["groups"]["numerics"])
    titles = [t["title"] for t in kind.summary_tables(res.summary)]
    closed = spec.control.mode == "closed_loop"
    assert ("open vs closed loop: the answer with and without its correction" in titles) == closed
    assert ("held-out, same gait without the correction" in rows) == closed

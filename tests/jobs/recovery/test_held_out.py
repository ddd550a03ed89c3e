"""The held-out random models (issue 24) and the closed-loop job's report of the answer
both ways."""

import dataclasses

import mujoco
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


IDENTITY = {"friction_scale": 1.0, "mass_scale": 1.0, "payload_share": 0.0, "payload_x_m": 0.0, "payload_y_m": 0.0,
            "motor_strength": 1.0, "servo_gain_scale": 1.0, "floor_amplitude_m": 0.0, "floor_seed": 7}


@pytest.mark.parametrize("lost", [(1, 6), (3, 4)])
def test_a_flat_floor_walks_as_the_plane(lost):
    """Issue 47: the held-out model with every draw at its identity (the plane replaced by a
    flat height field, nothing else) and the rough floor at amplitude 0 walk a Table II
    answer (seed 0) as the nominal model does, within the timestep check's tolerance; so does
    a 0.5 mm floor (the floor converges to the plane, not only at 0). On the old 4 cm grid
    both answers failed it (the identity model walked them 15 % and 11 % shorter)."""
    import json
    from pathlib import Path

    from app.jobs.recovery.cases import FLOOR_CELL_M, perturbation
    from app.jobs.recovery.reproduce.convergence import RULE, halving_deltas
    from app.jobs.recovery.robust import MultiModelEvaluator
    from app.jobs.recovery.run import set_up
    from app.sim.perturb import Perturbation, perturbed_model, roughen_floor

    row = next(r for r in json.loads(Path("docs/table2.json").read_text())
               if tuple(r["lost_legs"]) == lost and r["seed"] == 0 and r["timestep_s"] == RecoverySpec().sim.timestep_s)
    job = set_up(RecoverySpec(damage={"lost_legs": list(lost)}))
    mass = job.robot.geometry.total_mass
    flat = Perturbation("flat", "flat height field", terrain_amplitude_m=0.0, terrain_cell_m=FLOOR_CELL_M)
    fine = dataclasses.replace(perturbation("rough_terrain", mass), terrain_amplitude_m=0.0005)
    models = [job.model, random_models(job.mspec, [IDENTITY], mass)[0],
              roughen_floor(job.mspec.copy(), flat).compile(), perturbed_model(job.mspec, fine, job.model)]
    assert all(m.geom_type[m.geom("floor").id] == mujoco.mjtGeom.mjGEOM_HFIELD for m in models[1:])
    ev = MultiModelEvaluator(job.robot, models, job.seq, job.ev.cfg)
    try:
        r = ev.evaluate_all(np.array([list(row["best_params"].values())])).metrics
    finally:
        ev.close()
        job.close()
    assert r["y_f_m"][0, 0] == pytest.approx(row["best"]["y_f_m"])  # the documented walk
    for k in range(1, len(models)):
        d = halving_deltas({key: v[:, 0] for key, v in r.items()}, {key: v[:, k] for key, v in r.items()})
        assert not r["fell"][0, k]
        assert d["forward_rel"][0] < RULE["forward_rel"], (k, d)
        assert d["lateral_m"][0] < RULE["lateral_m"] and d["yaw_deg"][0] < RULE["yaw_deg"], (k, d)

"""The closed-loop heading and drift correction (issue 24): the same physics as the open
loop when it does nothing, a real correction when it acts, tips inside the workspace."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from app.jobs.base import SpecError
from app.jobs.recovery import gait_controller
from app.jobs.recovery.cases import walking_cases
from app.jobs.recovery.closedloop import Law, law_of
from app.jobs.recovery.evaluate import GaitEvaluator
from app.jobs.recovery.robust import case_models
from app.jobs.recovery.run import search_bounds, sim_config, sim_model
from app.jobs.recovery.sequences import plan_hexapod
from app.jobs.recovery.spec import RecoverySpec
from app.robots.catalog import get_robot
from app.robots.ik import leg_fk, leg_ik

DOCS = Path(__file__).resolve().parents[3] / "docs"


def table2_answer(lost):
    rows = [r for r in json.loads((DOCS / "table2.json").read_text()) if tuple(r["lost_legs"]) == tuple(lost)]
    return rows[0]


def setting(lost, control=None, duration_s=10.0):
    spec = RecoverySpec.parse({"damage": {"lost_legs": list(lost)}, "control": control or {},
                               "sim": {"duration_s": duration_s}})
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    return spec, robot, mspec, model, seq


def test_the_controller_runs_the_robot_layers_ik():
    """One source: the controller's IK is app/robots/ik.py's function itself, not a copy."""
    assert gait_controller.leg_ik is leg_ik


def test_open_loop_is_the_default_and_the_gains_are_bounded():
    assert RecoverySpec().control.mode == "open_loop"
    assert sim_config(RecoverySpec()).law is None
    for field, value in (("yaw_gain", -0.1), ("stride_limit_m", 0.05), ("lateral_limit_m", 1.0), ("mode", "pid")):
        with pytest.raises(SpecError) as e:
            RecoverySpec.parse({"control": {"mode": "closed_loop", field: value}})
        assert e.value.errors[0]["field"] == f"control.{field}"


def test_a_correction_that_does_nothing_walks_the_open_loop_gait_exactly():
    """Zero gains: the closed-loop rollout applies the open loop's set-points bit for bit
    (computed by the shipped module, chunk by chunk at the update ticks), and walks the same
    walk: only to 1e-9, since a chunk boundary restarts the solver's warm start (not part of
    the physics state a rollout carries) and the two loops cut their chunks elsewhere."""
    lost = (1, 6)
    zero = {"mode": "closed_loop", "yaw_gain": 0.0, "yaw_integral_gain": 0.0, "lateral_gain": 0.0,
            "lateral_integral_gain": 0.0, "update": "phase"}
    spec, robot, _, model, seq = setting(lost, zero, duration_s=3.0)
    x = np.array([list(table2_answer(lost)["best_params"].values())])
    x = np.vstack([x, x * 1.03])
    closed = GaitEvaluator(robot, model, seq, sim_config(spec))
    opened = GaitEvaluator(robot, model, seq, sim_config(spec, open_loop=True))
    assert closed.cfg.law is not None and opened.cfg.law is None
    a, b = closed.evaluate(x).metrics, opened.evaluate(x).metrics
    for k in a:
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-9)
    ta, tb = closed.trace(x[:1]), opened.trace(x[:1])
    np.testing.assert_array_equal(ta["ctrl"], tb["ctrl"])
    np.testing.assert_allclose(ta["qpos"], tb["qpos"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("update", ["period", "phase"])
def test_the_correction_holds_heading_and_line_where_the_open_loop_gait_turns(update):
    """Table II's legs 1 & 6 answer on a floor of 0.7 x the friction: open loop it ends far
    off its line and heading; the correction (IMU + odometry) brings both back."""
    lost = (1, 6)
    spec, robot, mspec, model, seq = setting(lost, {"mode": "closed_loop", "update": update})
    slippery = case_models(mspec, model, walking_cases(robot.geometry.total_mass, ["friction_0.7"]))[0]
    x = np.array([list(table2_answer(lost)["best_params"].values())])
    opened = GaitEvaluator(robot, slippery, seq, sim_config(spec, open_loop=True)).evaluate(x).metrics
    closed = GaitEvaluator(robot, slippery, seq, sim_config(spec)).evaluate(x).metrics
    assert abs(opened["yaw_f_deg"][0]) > 20 or abs(opened["x_f_m"][0]) > 0.1
    assert abs(closed["yaw_f_deg"][0]) < 5 and abs(closed["x_f_m"][0]) < 0.03
    assert not closed["fell"][0]


def test_the_imu_alone_corrects_heading_without_odometry():
    lost = (1, 6)
    spec, robot, mspec, model, seq = setting(lost, {"mode": "closed_loop", "odometry": False})
    slippery = case_models(mspec, model, walking_cases(robot.geometry.total_mass, ["friction_0.7"]))[0]
    x = np.array([list(table2_answer(lost)["best_params"].values())])
    ev = GaitEvaluator(robot, slippery, seq, sim_config(spec))
    m = ev.evaluate(x).metrics
    ev.trace(x)
    assert abs(m["yaw_f_deg"][0]) < 5
    assert ev.recorded["commands"][0, 1] == 0.0  # no sideways stride without odometry


@pytest.mark.parametrize("lost", [(1, 6), (3, 4), (1,), (4,)])
def test_every_corrected_tip_stays_in_reach_at_the_largest_limits(lost):
    """The spec's largest limits, saturated both ways, on every Table II answer: the IK
    reaches every corrected tip (forward kinematics gives it back), and each leg's stride
    stays inside the search's step-length bounds."""
    spec, robot, _, model, seq = setting(lost)
    lower, upper = search_bounds(spec, robot)
    law = Law(1.0, 0.0, 5.0, 0.0, 0.03, 0.03, stride_bounds=(lower[-2], upper[-2]))
    ev = GaitEvaluator(robot, model, seq, dataclasses.replace(sim_config(spec), law=law))
    x = np.array([list(table2_answer(lost)["best_params"].values())])
    n = len(ev.legs)
    for cmd in ([0.03, 0.03], [-0.03, -0.03], [0.03, -0.03], [-0.03, 0.03]):
        ctl = gait_controller.GaitController(ev.period_tips(x), ev.stride_shape(), x[:, 2 * n], ev.sides,
                                             robot.geometry.link_lengths, law.stride_bounds, ev.n_period,
                                             law.as_dict())
        ctl.cmd_prev[:] = ctl.cmd[:] = cmd
        tips = ctl.tips(0, ev.n_period)
        leg = tips.copy()
        leg[..., 1] *= ev.sides
        np.testing.assert_allclose(leg_fk(leg_ik(leg, robot.geometry.link_lengths), robot.geometry.link_lengths),
                                   leg, atol=1e-9)
        stride = tips[..., 1].max(axis=1) - tips[..., 1].min(axis=1)  # (1, nlegs)
        assert np.all(stride <= max(upper[-2], x[0, 2 * n]) + 1e-12)
        assert np.all(stride >= min(lower[-2], x[0, 2 * n]) - 1e-12)


def test_law_of_reads_the_spec():
    spec = RecoverySpec.parse({"control": {"mode": "closed_loop", "yaw_gain": 0.2, "update": "phase"}})
    law = law_of(spec.control, (0.02, 0.05))
    assert law.yaw_gain == 0.2 and law.update == "phase" and law.stride_bounds == (0.02, 0.05)
    assert law.update_steps(600, 3) == 200 and dataclasses.replace(law, update="period").update_steps(600, 3) == 600

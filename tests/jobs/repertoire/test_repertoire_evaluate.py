"""The batched evaluator against a slow reference (one gait, one mj_step at a time, the
metrics computed from the whole recorded trial), on the built-in hexapod under damage and
on an uploaded robot (Gymnasium's Ant, from its wheel); the map's damage changes the
descriptor's legs."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[2] / "robots"))
import legged_models as lm_  # noqa: E402

from app.jobs.registry import parse_spec  # noqa: E402
from app.jobs.repertoire.body import STATE, build  # noqa: E402
from app.jobs.repertoire.evaluate import Evaluator, heading_axes  # noqa: E402
from app.jobs.repertoire.run import layout_of  # noqa: E402
from app.robots.detect import detect_legs  # noqa: E402
from app.robots.legmap import Robot  # noqa: E402

RID = "cd" * 16


def _spec(**over) -> object:
    return parse_spec({"kind": "repertoire", "sim": {"duration_s": 0.6, "settle_s": 0.1, "timestep_s": 0.002},
                       **over})


def reference(ev: Evaluator, x: np.ndarray) -> dict:
    """One gait stepped by mj_step with its set-points computed tick by tick."""
    m = ev.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, ev.body.state0, STATE)
    mujoco.mj_forward(m, d)
    sens = [d.sensordata.copy()]
    for k in range(ev.nstep):
        d.ctrl[:] = ev.layout.setpoints_single(x, (k - ev.n_settle) * ev.dt)
        mujoco.mj_step(m, d)
        sens.append(d.sensordata.copy())
    sens = np.array(sens)  # row 0: the first state; row k: after step k

    def read(name, rows):
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name)
        return rows[..., m.sensor_adr[i]:m.sensor_adr[i] + m.sensor_dim[i]]

    start, end, walk = sens[ev.n_settle], sens[-1], sens[ev.n_settle + 1:]
    f0 = heading_axes(read("torso_quat", start))[0][:2]
    f0 /= np.linalg.norm(f0)
    f1 = heading_axes(read("torso_quat", end))[0][:2]
    move = (read("com_pos", end) - read("com_pos", start))[:2]
    feet = np.concatenate([read(f, walk) for f in ev.body.feet], axis=-1)
    power = sum(np.abs(read(f"rep_force_{a}", walk) * read(f"rep_speed_{a}", walk)) for a in range(m.nu))
    up = np.array([heading_axes(q)[1][2] for q in read("torso_quat", sens[1:])])
    return {"forward_m": move @ f0, "lateral_m": move @ np.array([-f0[1], f0[0]]),
            "yaw_deg": np.degrees(np.arctan2(f0[0] * f1[1] - f0[1] * f1[0], f0 @ f1)),
            "contact": (feet > 0).mean(axis=0), "energy_j": float(power.sum()) * ev.dt,
            "tilted": bool(np.any(up < np.cos(np.radians(60.0))))}


def _check(ev: Evaluator, xs: np.ndarray) -> dict:
    got = ev.evaluate(xs)
    for i, x in enumerate(xs):
        ref = reference(ev, x)
        for k in ("forward_m", "lateral_m", "yaw_deg", "energy_j"):
            assert got[k][i] == pytest.approx(ref[k], rel=1e-9, abs=1e-9), k
        np.testing.assert_allclose(got["contact"][i], ref["contact"], atol=1e-12)
        if ref["tilted"]:
            assert got["fell"][i]
    assert np.all(got["timestep_s"] == ev.dt)
    return got


def test_the_batched_evaluator_matches_one_gait_stepped_at_a_time_on_the_damaged_hexapod():
    spec = _spec(damage={"lost_legs": ["leg3"], "locked_joints": [{"leg": "leg2", "joint": "leg2_femur"}]})
    body = build(spec)
    assert body.legs == ["leg1", "leg2", "leg4", "leg5", "leg6"] and len(body.joints) == 5 * 3 - 1
    layout = layout_of(spec, body)
    assert layout.dim == 3 * 14 + 1
    ev = Evaluator(body, layout, spec.sim.duration_s, spec.sim.settle_s, nthread=2)
    try:
        xs = np.random.default_rng(0).uniform(size=(3, layout.dim))
        got = _check(ev, xs)
        assert got["contact"].shape == (3, 5) and np.all(got["energy_j"] > 0)
        still = np.zeros((1, layout.dim))
        still[0, 2::3] = 0.5  # no amplitude, no offset: the robot stands
        standing = ev.evaluate(still)
        assert abs(standing["forward_m"][0]) < 1e-3 and not standing["fell"][0]
        assert np.sum(standing["contact"][0] > 0.9) >= 3  # it stands on at least three feet
    finally:
        ev.close()


@pytest.fixture(scope="module")
def ant() -> Robot:
    path = lm_.gymnasium_ant()
    assert path is not None, "gymnasium is missing: the test extra brings it (pip install -e '.[test]')"
    model = mujoco.MjModel.from_xml_path(str(path))
    return Robot("ant", path.read_text(), {}, detect_legs(model))


def test_an_uploaded_robot_runs_the_controller_by_its_leg_map(ant):
    lost = ant.legs.legs[0].name
    spec = _spec(robot=RID, damage={"lost_legs": [lost]})
    body = build(spec, ant)
    assert len(body.legs) == 3 and lost not in body.legs and len(body.joints) == 6  # hip and ankle per leg
    assert body.info["stance"] == "reference pose clipped to the joint ranges"
    layout = layout_of(spec, body)
    assert layout.dim == 19
    assert np.all(layout.stance >= body.lo) and np.all(layout.stance <= body.hi)
    ev = Evaluator(body, layout, spec.sim.duration_s, spec.sim.settle_s, nthread=1)
    try:
        _check(ev, np.random.default_rng(1).uniform(size=(2, layout.dim)))
    finally:
        ev.close()


def test_a_map_of_an_uploaded_robot_under_a_locked_joint_by_displacement(ant):
    from app.jobs.base import MemoryContext
    from app.jobs.registry import get_kind

    leg = ant.legs.legs[1]
    spec = parse_spec({"kind": "repertoire", "robot": RID, "seed": 1, "archive": {"cells": 12},
                       "damage": {"locked_joints": [{"leg": leg.name, "joint": leg.joints[1], "angle_deg": 30.0}]},
                       "descriptor": {"type": "displacement", "forward_m": [-0.3, 0.3], "lateral_m": [-0.2, 0.2]},
                       "search": {"iterations": 2, "batch_size": 4}, "evidence": {"rescore_elites": 0},
                       "sim": {"duration_s": 0.4, "settle_s": 0.1, "timestep_s": 0.002}})
    res = get_kind("repertoire").run(spec, MemoryContext(robots=lambda rid: ant))
    s = res.summary
    assert s["robot"]["servos"] == 7 and s["controller"]["parameters"] == 22  # one ankle locked
    assert s["descriptor"] == {"type": "displacement", "names": ["forward_m", "lateral_m"],
                               "bounds": [[-0.3, 0.3], [-0.2, 0.2]]}
    for (fwd, lat), f in zip(s["elites"]["measures"], s["elites"]["objective"]):
        assert -0.3 <= fwd <= 0.3 and -0.2 <= lat <= 0.2 and fwd == pytest.approx(max(-0.3, min(0.3, f)))
    assert sorted(s["robot"]["legs"]) == sorted(l.name for l in ant.legs.legs)  # a locked joint keeps its leg
    assert all(len(c) == 4 for c in s["elites"]["contact"])

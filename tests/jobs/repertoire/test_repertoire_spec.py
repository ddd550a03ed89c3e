"""The repertoire spec refuses bad input by field name (issue 43): reversed descriptor or
period bounds, an archive of 10^9 cells, a trial of 0 s, a robot without a leg map, damage
naming legs or joints the robot lacks; strict types, finite numbers, bounded lists."""

from __future__ import annotations

import math

import pytest

from app.jobs.base import SpecError
from app.jobs.registry import get_kind, parse_spec


def _fields(data: dict) -> dict[str, str]:
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "repertoire", **data})
    return {x["field"]: x["message"] for x in e.value.errors}


@pytest.mark.parametrize("data, field, words", [
    ({"descriptor": {"type": "displacement", "forward_m": [0.5, -0.5]}}, "descriptor.forward_m", "reversed"),
    ({"descriptor": {"lateral_m": [0.2, 0.2]}}, "descriptor.lateral_m", "reversed"),
    ({"controller": {"period_s": [1.0, 0.5]}}, "controller.period_s", "reversed"),
    ({"archive": {"cells": 10**9}}, "archive.cells", "100000"),
    ({"sim": {"duration_s": 0.0}}, "sim.duration_s", ""),
    ({"sim": {"duration_s": math.nan}}, "sim.duration_s", "finite"),
    ({"robot": "lizard"}, "robot", "leg map"),
    ({"robot": "silo6"}, "robot", "leg map"),
    ({"search": {"batch_size": "8"}}, "search.batch_size", ""),
    ({"search": {"iterations": 2.0}}, "search.iterations", ""),
    ({"archive": {"admit_fallen": 1}}, "archive.admit_fallen", ""),
    ({"damage": {"lost_legs": ["leg7"]}}, "damage.lost_legs", "leg7"),
    ({"damage": {"lost_legs": ["leg1", "leg1"]}}, "damage", "once"),
    ({"damage": {"lost_legs": [f"leg{i}" for i in range(1, 7)]}}, "damage.lost_legs", "at least one leg"),
    ({"damage": {"locked_joints": [{"leg": "leg2", "joint": "leg3_femur"}]}}, "damage.locked_joints", "leg3_femur"),
    ({"damage": {"locked_joints": [{"leg": "leg2", "joint": "leg2_femur", "angle_deg": 200.0}]}},
     "damage.locked_joints.0.angle_deg", "180"),
    ({"damage": {"lost_legs": ["leg1"] * 17}}, "damage.lost_legs", "16"),
    ({"evidence": {"rescore_elites": -1}}, "evidence.rescore_elites", "0"),
    ({"gravity": 1}, "gravity", "unknown field"),
])
def test_bad_input_is_refused_naming_the_field(data, field, words):
    errors = _fields(data)
    assert field in errors, errors
    assert words in errors[field], errors


def test_the_default_spec_states_its_budget_and_the_damage_by_leg_map_names():
    spec = get_kind("repertoire").default_spec()
    assert spec.robot == "jethexa" and spec.seed == 0
    assert spec.evaluations_budget == 2 * spec.search.iterations * spec.search.batch_size + 20 + 1
    damaged = parse_spec({"kind": "repertoire", "damage": {
        "lost_legs": ["leg3"], "locked_joints": [{"leg": "leg2", "joint": "leg2_femur", "angle_deg": 10.0}]}})
    assert get_kind("repertoire").damage_text(damaged) == "lost leg3; locked leg2_femur at 10 deg"
    uploaded = parse_spec({"kind": "repertoire", "robot": "ab" * 16, "damage": {"lost_legs": ["front_left"]}})
    assert uploaded.damage.lost_legs == ["front_left"]  # checked against the stored leg map before queueing
    legs = {"trunk": "torso", "legs": [
        {"name": n, "side": s, "order": o, "joints": [f"{n}_hip"], "foot": {"kind": "body", "name": f"{n}_foot"}}
        for n, s, o in (("front_left", "left", 0), ("front_right", "right", 0))]}
    assert get_kind("repertoire").user_robot_error(uploaded, legs) is None
    bad = parse_spec({"kind": "repertoire", "robot": "ab" * 16, "damage": {"lost_legs": ["hind_left"]}})
    assert "hind_left" in get_kind("repertoire").user_robot_error(bad, legs)

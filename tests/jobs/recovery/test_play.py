"""The recovery kind's ``Kind.play`` (app/jobs/recovery/play.py): an answer walked on the robot
as it is (another damage, a perturbed world), as the adaptation's evaluation tries the DE
answer of a believed damage on a simulated reality (app/adapt/reproduce/evaluation.py)."""

from __future__ import annotations

import pytest

from app.jobs.base import MemoryContext
from app.jobs.registry import get_kind, parse_spec
from app.sim.perturb import Perturbation

KIND = get_kind("recovery")
BASE = {"kind": "recovery", "search": {"population": 6, "generations": 2, "seed": 3}, "sim": {"duration_s": 1.0},
        "controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 0}}


@pytest.fixture(scope="module")
def answer():
    spec = parse_spec(BASE | {"robot_damage": {"lost_legs": ["leg3"]}})
    s = KIND.run(spec, MemoryContext()).summary
    names = s["bounds"]["names"]
    return spec, names, [s["best"]["params"][n] for n in names], s["best"]["metrics"]


def test_an_answer_played_on_its_own_robot_and_world_walks_as_the_job_scored_it(answer):
    spec, names, x, metrics = answer
    m = KIND.play(spec, [x, x], names)
    assert m["forward_m"] == [metrics["y_f_m"]] * 2  # bit for bit, and the same in a batch of two
    assert m["lateral_m"][0] == -metrics["x_f_m"] and m["yaw_deg"][0] == metrics["yaw_f_deg"]
    assert m["fell"] == [bool(metrics["fell"])] * 2 and m["duration_s"] == [1.0, 1.0]


def test_another_damage_and_world_change_the_walk_and_lost_legs_must_match(answer):
    spec, names, x, metrics = answer
    true = parse_spec(BASE | {"robot_damage": {"lost_legs": ["leg3"], "locked_joints": [
        {"leg": "leg2", "joint": "leg2_femur", "angle_deg": 25.0}]}})
    locked = KIND.play(true, [x], names)
    slippery = KIND.play(spec, [x], names, Perturbation("ice", "friction x0.3", friction_scale=0.3))
    assert locked["forward_m"][0] != metrics["y_f_m"] and slippery["forward_m"][0] != metrics["y_f_m"]
    other = parse_spec(BASE | {"robot_damage": {"lost_legs": ["leg4"]}})
    with pytest.raises(ValueError, match="lose the same legs"):
        KIND.play(other, [x], names)
    with pytest.raises(ValueError, match="parameters"):
        KIND.play(spec, [x[:-1]], [])

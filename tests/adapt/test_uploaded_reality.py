"""A simulated reality of an uploaded robot (issue 44): the Gymnasium ant prepared as an
upload is, its damages by its leg map's names, its recovery target scaled by its measured
leg length, a tiny map of it played on a damaged, perturbed ant, and the evaluation's
realities of five damage types drawn the same again."""

from __future__ import annotations

import pytest

from app.adapt.maps import read_repertoire
from app.adapt.reality import Reality, play, play_many
from app.adapt.recovered import leg_length_m, target_speed
from app.adapt.reproduce import evaluation as E
from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec
from app.robots.walkable import foot_segment_m


@pytest.fixture(scope="module")
def ant():
    return E.profile_of(E.ANT)


@pytest.fixture(scope="module")
def ant_map(ant, tmp_path_factory):
    spec = parse_spec({"kind": "repertoire", "robot": ant.robot, "seed": 3, "archive": {"cells": 20},
                       "search": {"iterations": 3, "batch_size": 8, "checkpoint_every": 3},
                       "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
                       "evidence": {"rescore_elites": 0, "random_control": False}})
    path = tmp_path_factory.mktemp("ant") / "intact.json"
    path.write_text(dumps(get_kind("repertoire").run(spec, MemoryContext(robots=ant.robots)).summary))
    return read_repertoire(path, "intact")


def test_an_uploaded_reality_needs_its_robot_and_its_leg_maps_names(ant):
    data = {"robot": ant.robot, "damage": {"lost_legs": ["back_leg"]}}
    with pytest.raises(SpecError) as e:
        Reality.parse(data)  # no loader: the id alone is not a robot
    assert e.value.errors[0]["field"] == "robot"
    r = Reality.parse(data, ant.robots)
    assert r.stored is ant.stored and r.damage.lost_legs == ["back_leg"]
    with pytest.raises(SpecError) as e:
        Reality.parse({"robot": ant.robot, "damage": {"lost_legs": ["leg1"]}}, ant.robots)  # the hexapod's name
    assert e.value.errors[0]["field"] == "damage"
    with pytest.raises(SpecError):
        Reality.parse({"robot": "f" * 32}, ant.robots)  # another id: not this evaluation's robot


def test_the_ants_target_is_the_hexapods_scaled_by_its_measured_leg_length(ant):
    ant_leg = leg_length_m(ant.robot, ant.stored)
    assert 0.5 < ant_leg < 1.2  # hip to ankle to foot, about 0.28 + 0.57 m on the ant's model
    assert target_speed(ant.robot, ant.stored) == pytest.approx(target_speed("jethexa") * ant_leg / 0.245)
    assert foot_segment_m(ant.stored, "back_leg") < ant_leg


def test_the_ants_realities_are_of_five_types_none_a_maps_and_redrawn_the_same(ant):
    drawn = [E.draw_reality(0, k, ant) for k in range(10)]
    assert [d["type"] for d in drawn[:5]] == list(E.ANT_TYPES) and drawn == [E.draw_reality(0, k, ant)
                                                                             for k in range(10)]
    for d in drawn:
        assert d["reality"]["damage"] not in E.ANT_PRIOR_DAMAGES.values()
        assert "front_left_leg" not in d["reality"]["damage"].get("lost_legs", [])
        Reality.parse(d["reality"], ant.robots)  # every draw is a valid reality of the ant
    assert E.draw_reality(0, 1) != E.draw_reality(0, 1, ant)  # the hexapod's draws are its own


def test_a_map_of_the_ant_plays_on_a_damaged_perturbed_ant(ant, ant_map):
    nominal = Reality.parse({"robot": ant.robot}, ant.robots)
    batch = play_many(nominal, ant_map, range(len(ant_map.map.forward_m)))
    # on the intact ant in the nominal world an elite measures what the map recorded
    assert [m.forward_m for m in batch] == pytest.approx(list(ant_map.map.forward_m), abs=1e-9)
    hurt = Reality.parse({"robot": ant.robot, "damage": {"passive_joints": [{"leg": "back_leg", "joint": "hip_3"}]},
                          "perturbation": {"friction_scale": 0.7, "payload_kg": 0.3}}, ant.robots)
    m = play(hurt, ant_map, 0)
    assert m.forward_m != pytest.approx(batch[0].forward_m, abs=1e-6)  # the damage and world change the walk

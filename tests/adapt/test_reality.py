"""The simulated reality (app/adapt/reality.py), the maps read from repertoire results
(app/adapt/maps.py), the recovery definition, and `gaitmend adapt --simulate` end to end on
two tiny repertoires built here (an intact map and one for a lost leg)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from typer.testing import CliRunner

from app.adapt import methods as M
from app.adapt.maps import MapError, read_repertoire, read_repertoires
from app.adapt.reality import Reality, play
from app.adapt.recovered import recovered, target_speed
from app.cli import cli
from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec

# seconds, not minutes: a short trial at a coarse step, a few iterations, no controls
SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 8, "checkpoint_every": 4},
        "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
        "evidence": {"rescore_elites": 0, "random_control": False}}


def _build(path, damage=None, descriptor=None):
    spec = parse_spec(SPEC | ({"damage": damage} if damage else {}) | ({"descriptor": descriptor} if descriptor else {}))
    path.write_text(dumps(get_kind("repertoire").run(spec, MemoryContext()).summary))
    return path


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    d = tmp_path_factory.mktemp("maps")
    # ITE's map (contact shares of the six legs), and two over the displacement, one space for both
    disp = {"type": "displacement", "forward_m": [-0.3, 0.3], "lateral_m": [-0.3, 0.3]}
    return (_build(d / "intact.json"), _build(d / "lost_leg1.json", {"lost_legs": ["leg1"]}, disp),
            _build(d / "intact_disp.json", None, disp))


def _reality(tmp_path, data, name="reality.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


# -- the reality spec ---------------------------------------------------------------------------

@pytest.mark.parametrize("data, field", [
    ({"wind": 1}, "wind"),
    ({"perturbation": {"friction_scale": float("nan")}}, "perturbation.friction_scale"),
    ({"perturbation": {"friction_scale": "1.0"}}, "perturbation.friction_scale"),  # no coercion
    ({"perturbation": {"mass_scale": 9.0}}, "perturbation.mass_scale"),
    ({"perturbation": {"terrain_amplitude_m": -0.01}}, "perturbation.terrain_amplitude_m"),
    ({"perturbation": {"payload_offset_m": [0, 0, 1.0]}}, "perturbation.payload_offset_m.2"),
    ({"perturbation": {"gravity": 1}}, "perturbation.gravity"),
    ({"perturbation": {"motor_strength": 0.1}}, "perturbation.motor_strength"),
    ({"perturbation": {"servo_gain_scale": float("inf")}}, "perturbation.servo_gain_scale"),
    ({"damage": {"lost_legs": ["leg9"]}}, "damage.lost_legs"),
    ({"damage": {"lost_legs": ["leg1", "leg1"]}}, "damage"),
    ({"damage": {"weak_joints": [{"leg": "leg2", "joint": "leg2_femur", "torque_scale": 1.5}]}},
     "damage.weak_joints.0.torque_scale"),  # the one vocabulary's bounds
    ({"damage": {"passive_joints": [{"leg": "leg9", "joint": "leg9_femur"}]}}, "damage.passive_joints"),
    ({"damage": {"locked_joints": [{"leg": "leg2", "joint": "leg2_knee"}]}}, "damage.locked_joints"),
    ({"robot": "ant"}, "robot"),
    ([], "reality"),
])
def test_a_bad_reality_names_its_field(data, field):
    with pytest.raises(SpecError) as e:
        Reality.parse(data)
    assert field in [err["field"] for err in e.value.errors], e.value.errors


def test_a_reality_turns_into_the_projects_perturbation():
    r = Reality.parse({"damage": {"lost_legs": ["leg3"], "locked_joints": [{"leg": "leg2", "joint": "leg2_femur",
                                                                             "angle_deg": 10.0}]},
                       "perturbation": {"friction_scale": 0.5, "payload_kg": 1.0, "terrain_amplitude_m": 0.005}})
    p = r.perturbation.perturbation()
    assert (p.friction_scale, p.payload_kg, p.terrain_amplitude_m, p.payload_body) == (0.5, 1.0, 0.005, "torso")
    assert p.structural and r.damage.lost_legs == ["leg3"]


# -- maps ---------------------------------------------------------------------------------------

def test_a_result_reads_as_a_map(maps, tmp_path):
    rep = read_repertoire(maps[0])
    s = json.loads(maps[0].read_text())
    n = len(s["elites"]["cell"])
    assert rep.map.name == "intact" and rep.map.descriptors.shape == (n, 6) and rep.params.shape == (n, 55)
    assert np.all((rep.map.descriptors >= 0) & (rep.map.descriptors <= 1))
    assert rep.map.trial_s == 1.0 and rep.map.forward_m.tolist() == s["elites"]["objective"]
    # a bundle zip holds the same result
    z = tmp_path / "b.zip"
    with zipfile.ZipFile(z, "w") as f:
        f.writestr("result.json", maps[0].read_text())
    assert read_repertoire(z).cells == rep.cells
    # a result whose JSON holds a NaN (Python's json writes it; orjson refuses it) reads the same
    nan = tmp_path / "nan.json"
    nan.write_text(json.dumps(json.loads(maps[0].read_text()) | {"note": float("nan")}))
    assert read_repertoire(nan).cells == rep.cells
    two = read_repertoires([maps[2], maps[2], maps[1]])
    assert [r.map.name for r in two] == ["intact", "intact (2)", "lost leg1"]
    assert two[1].map.descriptors.shape[1] == 2 and two[2].descriptor == ["forward_m", "lateral_m"]
    with pytest.raises(MapError, match="behaviour space"):
        read_repertoires([maps[0], maps[1]])
    with pytest.raises(MapError, match="not found"):
        read_repertoire(tmp_path / "none.json")
    (tmp_path / "x.json").write_text('{"kind": "recovery"}')
    with pytest.raises(MapError, match="not a repertoire"):
        read_repertoire(tmp_path / "x.json")


# -- trials on the reality ----------------------------------------------------------------------

def test_a_trial_is_deterministic_and_a_lost_leg_changes_it(maps):
    rep = read_repertoire(maps[0])
    i = int(np.argmax(rep.map.forward_m))
    intact = Reality.parse({})
    a, b = play(intact, rep, i), play(intact, rep, i)
    assert a == b
    # the intact, nominal reality is the map's own world: the elite walks what the map recorded
    assert a.forward_m == pytest.approx(rep.map.forward_m[i], abs=1e-9)
    assert a.lateral_m == pytest.approx(rep.map.lateral_m[i], abs=1e-9) and a.duration_s == pytest.approx(1.0)
    lost = play(Reality.parse({"damage": {"lost_legs": ["leg1"]}}), rep, i)
    assert lost != a and abs(lost.forward_m - a.forward_m) > 1e-3
    slippery = play(Reality.parse({"perturbation": {"friction_scale": 0.3}}), rep, i)
    assert slippery.forward_m != a.forward_m
    # every type of the one damage vocabulary is made on the reality's robot (app/robots/damage.py)
    for damage in ({"weak_joints": [{"leg": "leg2", "joint": "leg2_femur", "torque_scale": 0.05}]},
                   {"passive_joints": [{"leg": "leg2", "joint": "leg2_femur"}]},
                   {"shortened_legs": [{"leg": "leg2", "length_m": 0.04}]},
                   {"stiff_joints": [{"leg": "leg2", "joint": "leg2_femur", "friction": 5.0}]}):
        hurt = play(Reality.parse({"damage": damage}), rep, i)
        assert abs(hurt.forward_m - a.forward_m) + abs(hurt.lateral_m - a.lateral_m) > 1e-4, damage
    # the servos' strength and gains, the project's two servo draws (app/sim/servos.py): each changes the walk
    for world in ({"motor_strength": 0.3}, {"servo_gain_scale": 0.3}):
        weak = play(Reality.parse({"perturbation": world}), rep, i)
        assert abs(weak.forward_m - a.forward_m) + abs(weak.lateral_m - a.lateral_m) > 1e-4, world
    assert play(Reality.parse({"perturbation": {"motor_strength": 1.0, "servo_gain_scale": 1.0}}), rep, i) == a


def test_the_recovery_definition():
    assert target_speed("jethexa") == pytest.approx(0.05)
    assert recovered(0.5, False, 10.0, "jethexa") and recovered(0.05, False, 1.0, "jethexa")
    assert not recovered(0.049, False, 1.0, "jethexa") and not recovered(1.0, True, 1.0, "jethexa")


# -- the CLI ------------------------------------------------------------------------------------

def _last_json(out: str) -> dict:
    return json.loads(out.strip().splitlines()[-1])


def _follows_the_method(result: dict, paths, settings) -> None:
    reps = read_repertoires(list(paths))
    ms = [r.map for r in reps]
    trials = []
    for t in result["trials"]:
        p = M.propose(ms, trials, settings)
        assert (t["map"], t["elite"]) == (p.map, p.elite) and t["predicted"] == pytest.approx(p.predicted)
        trials.append(M.Trial(t["map"], t["elite"], t["forward_m"], t["lateral_m"], math.radians(t["yaw_deg"]),
                              t["fell"], t["duration_s"]))
    d = M.decide(ms, trials, settings)
    assert d.stop and d.reason == result["stop"]["reason"]
    assert result["final"] == result["trials"][d.best_trial]
    assert not M.decide(ms, trials[:-1], settings).stop


def test_adapt_on_a_simulated_reality_end_to_end(maps, tmp_path):
    reality = _reality(tmp_path, {"damage": {"lost_legs": ["leg1"]}, "perturbation": {"friction_scale": 0.8}})
    # a real process: the JSON is the last line of stdout alone
    res = subprocess.run([sys.executable, "-m", "app", "adapt", str(maps[0]), "--simulate", str(reality), "--json"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    out = _last_json(res.stdout)
    assert set(out) == {"method", "trials", "recovered_at", "target_m_s", "stop", "final"}
    assert out["method"] == "ite" and 1 <= len(out["trials"]) <= 20 and out["target_m_s"] == pytest.approx(0.05)
    assert [t["trial"] for t in out["trials"]] == list(range(1, len(out["trials"]) + 1))
    first = next((t["trial"] for t in out["trials"] if t["recovered"]), None)
    assert out["recovered_at"] == first
    for t in out["trials"]:
        assert t["recovered"] == (not t["fell"] and t["forward_m"] / t["duration_s"] >= 0.05)
    _follows_the_method(out, [maps[0]], M.ITE)
    # every trial is a row of the table before the JSON
    assert len([ln for ln in res.stdout.splitlines() if ln.strip()[:1].isdigit()]) == len(out["trials"])

    two = [maps[2], maps[1]]
    res = CliRunner().invoke(cli, ["adapt", *map(str, two), "--simulate", str(reality), "--method", "gaitmend",
                                   "--json"])
    assert res.exit_code == 0, res.output
    out = _last_json(res.output)
    assert out["method"] == "gaitmend"
    _follows_the_method(out, two, M.GAITMEND)


@pytest.mark.parametrize("case", ["unknown field", "nan", "missing reality", "bad method", "missing map",
                                  "map for another damage", "two spaces"])
def test_adapt_refuses_bad_input_with_exit_2(case, maps, tmp_path):
    reality = _reality(tmp_path, {})
    args, expect = {
        "unknown field": (["--simulate", str(_reality(tmp_path, {"perturbation": {"wind": 2}}, "r1.json"))],
                          "perturbation.wind"),
        "nan": (["--simulate", str(tmp_path / "nan.json")], "NaN"),
        "missing reality": (["--simulate", str(tmp_path / "none.json")], "not found"),
        "bad method": (["--simulate", str(reality), "--method", "bo"], "--method"),
        "missing map": (["--simulate", str(reality), str(tmp_path / "nomap.json")], "not found"),
        # the lost-leg map has no servos for leg 1, which the intact reality still has
        "map for another damage": (["--simulate", str(reality), "--json"], "leg1"),
        "two spaces": (["--simulate", str(reality), str(maps[1])], "behaviour space"),
    }[case]
    (tmp_path / "nan.json").write_text('{"perturbation": {"friction_scale": NaN}}')
    first = maps[1] if case == "map for another damage" else maps[0]
    res = CliRunner().invoke(cli, ["adapt", str(first), *args])
    assert res.exit_code == 2, res.output
    assert expect in res.output


def test_adapt_reads_a_labs_measurements_from_stdin(maps):
    """Without --simulate each proposal is printed with its gait and its measurement read
    from stdin; the loop is the same (each trial the method's proposal)."""
    poor = "0.0 0.01 -2.5 no 1.0\n"
    res = CliRunner().invoke(cli, ["adapt", str(maps[0]), "--json"], input=poor * 3)
    assert res.exit_code == 1, res.output  # the input ended before the method stopped
    out = _last_json(res.stdout)
    assert len(out["trials"]) == 3 and not out["stop"]["method_stopped"] and out["recovered_at"] is None
    assert "measurements ended after 3 trials" in out["stop"]["reason"]
    assert res.stdout.count("gait x = [") == 4  # the fourth proposal was shown, never measured
    reps = read_repertoires([maps[0]])
    trials = []
    for t in out["trials"]:
        p = M.propose([reps[0].map], trials, M.ITE)
        assert (t["map"], t["elite"], t["forward_m"], t["yaw_deg"], t["fell"]) == (p.map, p.elite, 0.0, -2.5, False)
        trials.append(M.Trial(t["map"], t["elite"], 0.0, 0.01, math.radians(-2.5), False, 1.0))

    # a trial far above every prediction stops ITE at once, and meets the recovery target
    res = CliRunner().invoke(cli, ["adapt", str(maps[0]), "--json"], input="2.0 0 0 yes 1\n1 0 0 no 1\n")
    assert res.exit_code == 0, res.output
    out = _last_json(res.stdout)
    assert [t["fell"] for t in out["trials"]] == [True] and out["recovered_at"] is None  # fell: not recovered
    res = CliRunner().invoke(cli, ["adapt", str(maps[0]), "--json"], input="1 0 0 no 1\n")
    out = _last_json(res.stdout)
    assert res.exit_code == 0 and out["recovered_at"] == 1 and out["stop"]["method_stopped"]


@pytest.mark.parametrize("line, field", [("0.1 0 0 maybe 1", "fell"), ("0.1 0 0 no 0", "duration_s"),
                                         ("nan 0 0 no 1", "forward_m"), ("0.1 0 0", "measurement"),
                                         ("0.1 x 0 no 1", "lateral_m")])
def test_a_bad_measurement_from_a_pipe_exits_2_naming_its_field(maps, line, field):
    res = CliRunner().invoke(cli, ["adapt", str(maps[0])], input=line + "\n")
    assert res.exit_code == 2 and field in res.output, res.output


def test_a_map_for_any_damage_type_is_named_by_it_never_intact():
    """Maps are named by their damage: lost and locked as the committed evaluations record
    them, every other type in the robot layer's words (a weak joint's map was "intact")."""
    from app.adapt.maps import damage_name

    assert damage_name({}) == "intact"
    assert damage_name({"lost_legs": ["leg1", "leg6"], "locked_joints": [
        {"leg": "leg2", "joint": "leg2_femur", "angle_deg": 10.0}]}) == "lost leg1, leg6; locked leg2.leg2_femur"
    assert damage_name({"lost_legs": [], "locked_joints": [], "weak_joints": [
        {"leg": "leg3", "joint": "leg3_coxa", "torque_scale": 0.2}]}) == "weak leg3_coxa at 20 % force"

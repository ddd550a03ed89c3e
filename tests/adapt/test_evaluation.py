"""The adaptation's evaluation (app/adapt/reproduce, `gaitmend reproduce adapt`) at the tests'
size: tiny maps, a few realities, seconds. The published run is docs/adapt.md's
"Evaluation", rendered from docs/adapt_evaluation.json (tests/test_docs_data.py holds the
page to its data)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.adapt import methods as M
from app.adapt.maps import HOLD, in_space_of
from app.adapt.reality import Reality, play, play_many
from app.adapt.reproduce import de_arm as D
from app.adapt.reproduce import evaluation as E
from app.adapt.reproduce.params import Params
from app.adapt.reproduce.report import render, summary


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("adapt_eval")
    p = Params(realities=3, quick=True, json_out=d / "evaluation.json", maps_dir=d / "maps")
    logs: list[str] = []
    text = E.reproduce(p, logs.append)
    reps, _ = E.build_maps(p, logs.append)
    return p, reps, json.loads(p.json_out.read_text()), text, logs


def test_realities_are_of_three_damage_types_none_a_maps_and_drawn_the_same_again():
    drawn = [E.draw_reality(0, k) for k in range(12)]
    assert {d["type"] for d in drawn} == set(E.TYPES) and len(E.TYPES) >= 3
    assert drawn == [E.draw_reality(0, k) for k in range(12)]
    for d in drawn:
        r = Reality.parse(d["reality"])  # valid realities
        assert d["reality"]["damage"] not in E.PRIOR_DAMAGES.values() and d["reality"]["damage"] != {}
        assert not set(r.damage.lost_legs) & {"leg1", "leg6"}  # the maps' lost legs are never a reality's


def test_a_lifted_map_holds_a_lost_legs_contact_at_zero_and_its_joints_still(run):
    _, reps, _, _, _ = run
    intact, lost = reps[0], next(r for r in reps if r.map.name == "lost leg1")
    assert lost.descriptor == intact.descriptor and lost.joints == intact.joints
    assert np.all(lost.map.descriptors[:, intact.descriptor.index("contact_leg1")] == 0.0)
    for j in ("leg1_coxa", "leg1_femur", "leg1_tibia"):
        i = intact.joints.index(j)
        assert np.all(lost.params[:, 3 * i:3 * i + 3] == HOLD)
    assert in_space_of(intact, intact) is intact


def test_a_gait_measures_the_same_alone_as_in_the_oracles_batch(run):
    _, reps, data, _, _ = run
    reality = Reality.parse(data["realities"][0]["reality"])
    for rep in reps[:2]:
        batch = play_many(reality, rep, range(len(rep.map.forward_m)))
        for i in (0, len(batch) - 1):
            alone = play(reality, rep, i)
            assert alone.forward_m == pytest.approx(batch[i].forward_m, abs=1e-9)
            assert alone.fell == batch[i].fell


def test_the_evaluation_appends_each_reality_and_continues_where_the_file_ends(run):
    p, _, data, text, _ = run
    assert [r["id"] for r in data["realities"]] == ["0-0", "0-1", "0-2"]
    arms = set(E.ARMS) | {E.RANDOM, D.DE_ARM}
    for r in data["realities"]:
        assert set(r["arms"]) == arms
        for name, a in r["arms"].items():
            assert a["trials"] <= E.MAX_TRIALS and (a["recovered_at"] is None or a["recovered_at"] <= a["trials"])
            if name != D.DE_ARM:  # nothing of the maps beats the oracle (the DE answer is not the maps')
                assert r["oracle"]["best_speed_m_s"] >= a["final_speed_m_s"] - 1e-12
        assert r["arms"][D.DE_ARM]["trials"] == 1
    assert data["setup"]["map_budget"] == E.QUICK_BUDGET and data["setup"]["de_believed"]["spec"] == D.DE_QUICK
    logs: list[str] = []
    again = E.reproduce(p, logs.append)  # nothing new to run
    assert json.loads(p.json_out.read_text())["realities"] == data["realities"]
    assert not any(line.startswith("reality") for line in logs) and again == text
    # the page's section is rendered from the file: its figures are the summary's
    s = summary(data)
    assert f"{s['arms']['gaitmend']['recovered']}/3" in render(data) and "Wilson" in render(data)
    assert "No evaluation has run yet" in render(None)


def test_an_arm_replays_the_loop_on_the_oracles_table(run):
    """The ITE arm's trials are the loop's own proposals measured from the table: the same
    trials as `gaitmend adapt --simulate` would play (app/adapt/simulate.py)."""
    _, reps, data, _, _ = run
    r = data["realities"][1]
    reality = Reality.parse(r["reality"])
    tables = E.oracle_tables(reality, reps)
    from app.adapt.simulate import adapt

    out = adapt(reps[:1], reality, M.ITE)
    assert E.tried_text([(x.proposal.map, x.proposal.elite) for x in out.rows]) == r["arms"]["ite"]["tried"]
    assert E.run_arm(reps[:1], tables, M.ITE, reality.robot)["recovered_at"] == out.recovered_at


def test_the_scenario_priors_are_the_pooled_elites_re_simulated_before_any_damage(run):
    p, reps, _, _, _ = run
    scen = E.scenario_maps(p, reps, lambda s: None)
    n = sum(len(r.map.forward_m) for r in reps)
    assert [m.map.name for m in scen][:2] == [E.SCENARIO_MEAN, "on intact"]
    assert all(len(m.map.forward_m) == n for m in scen)
    np.testing.assert_allclose(scen[0].map.forward_m, np.mean([m.map.forward_m for m in scen[1:]], axis=0))
    # the intact map's elites on the intact robot in the nominal world measure what the map recorded (a fall as 0)
    k = len(reps[0].map.forward_m)
    np.testing.assert_allclose(scen[1].map.forward_m[:k], reps[0].map.forward_m, rtol=0, atol=1e-9)
    worlds = E.scenario_maps(p, reps, lambda s: None, worlds=True)
    assert len(worlds) == 2 * len(scen) - 1
    realities = [E.draw_reality(p.seed, k)["reality"]["perturbation"] for k in range(30)]
    import app.adapt.reproduce.evaluation as ev

    trained = [ev.draw_world(np.random.default_rng([p.seed, ev.TRAIN_STREAM, i])) for i in range(4)]
    assert not any(w in realities for w in trained)


def test_a_lab_believes_every_lost_leg_and_all_but_the_last_joint_fault():
    lost = {"lost_legs": ["leg2"]}
    assert D.believed_damage(lost) == lost
    two = {"locked_joints": [{"leg": "leg1", "joint": "leg1_coxa", "angle_deg": 5.0},
                             {"leg": "leg2", "joint": "leg2_tibia", "angle_deg": -5.0}]}
    assert D.believed_damage(two) == {"locked_joints": two["locked_joints"][:1]}
    both = lost | {"locked_joints": two["locked_joints"][:1], "weak_joints": [
        {"leg": "leg4", "joint": "leg4_femur", "torque_scale": 0.3}]}
    assert D.believed_damage(both) == lost | {"locked_joints": two["locked_joints"][:1]}  # the weak joint, last listed
    assert D.believed_damage(lost | {"locked_joints": two["locked_joints"][:1]}) == lost


def test_the_de_arm_is_the_recovery_answer_of_the_believed_damage_tried_on_the_reality(run):
    p, _, data, _, _ = run
    r = next(x for x in data["realities"] if x["type"] == "lost_leg_and_locked_joint")
    de = r["arms"][D.DE_ARM]
    assert de["believed_damage"] == {"lost_legs": r["reality"]["damage"]["lost_legs"]}
    k = int(r["id"].rsplit("-", 1)[1])
    again = D.run_de_believed({x: r[x] for x in ("id", "type", "reality")}, p.seed * 100_003 + k,
                              E.profile_of(E.ROBOT), quick=True)
    assert {a: v for a, v in again.items() if a != "seconds"} == {a: v for a, v in de.items() if a != "seconds"}
    # played on the believed damage in the nominal world, the answer walks as its job scored it; on the reality not
    from app.jobs.base import MemoryContext
    from app.jobs.registry import get_kind, parse_spec

    seed = p.seed * 100_003 + k
    spec = parse_spec(D.DE_QUICK | {"robot_damage": de["believed_damage"],
                                    "search": D.DE_QUICK["search"] | {"seed": seed}})
    job = get_kind("recovery").run(spec, MemoryContext()).summary
    assert job["best"]["metrics"]["y_f_m"] == de["believed_forward_m"]
    assert de["final_speed_m_s"] * spec.sim.duration_s != de["believed_forward_m"]  # the reality changes the walk
    # a DE pass alone (--de-only) on a file that has every reality's DE runs nothing
    logs: list[str] = []
    E.reproduce(p.model_copy(update={"de_only": True}), logs.append)
    assert not logs

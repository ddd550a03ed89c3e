"""The recovery job end to end on the real simulator, at small budgets."""

import copy
import json

import numpy as np
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


def spec_evaluations(d):
    return parse_spec(d).evaluations_budget


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
    assert s["timing"]["evaluations"] == spec_evaluations(SMALL) == 8 * 5 * 2 + 7 + 3 + 20  # 20 held-out models
    assert set(s["best"]["metrics"]) == {"x_f_m", "y_f_m", "yaw_f_deg", "roll_amp_deg", "pitch_amp_deg",
                                         "tilt_max_deg", "under_3_feet_frac", "fell"}
    assert res.model_xml.startswith("<mujoco") and "leg1_coxa" not in res.model_xml


def test_same_seed_same_numbers(small_run, tmp_path):
    spec, res = small_run
    again = run(spec, Ctx(tmp_path))
    assert numbers(again.summary) == numbers(res.summary)


@pytest.mark.parametrize("stop_after, phase", [(2, "search"), (56, "random_search")])
def test_resume_from_checkpoint_gives_the_uninterrupted_result(small_run, tmp_path, stop_after, phase):
    """Killed in the search, or in the control between generations whose walks were cut
    against its best so far (8 x 5 walks of search, then the control's)."""
    spec, res = small_run
    ctx = Ctx(tmp_path, stop_after=stop_after)
    with pytest.raises(KeyboardInterrupt):
        run(spec, ctx)
    assert ctx.progress_calls[-1][2]["phase"] == phase
    resumed = run(spec, Ctx(tmp_path, checkpoint=ctx.checkpoints[-1]))
    assert numbers(resumed.summary) == numbers(res.summary)


def test_cancel_is_seen_between_generations(tmp_path):
    ctx = Ctx(tmp_path, cancel_after=2)
    with pytest.raises(Cancelled):
        run(parse_spec(SMALL), ctx)
    assert len(ctx.checkpoints) == 2


def test_cmaes_option_runs(tmp_path):
    """optimizer: cmaes drives the search with CMA-ES: a fresh CMA-ES on the same bounds and
    seed, told the fitness values the run recorded, proposes exactly the candidates the run
    scored, and the answer is the one it proposed with the best value of all generations."""
    from app.optim.cmaes import CMAES

    spec = parse_spec(SMALL | {"search": {"optimizer": "cmaes", "population": 8, "generations": 2, "seed": 0}})
    ctx = Ctx(tmp_path)
    s = run(spec, ctx).summary
    told = ctx.checkpoints[-1]["search"]["optimizer"]["told"]
    assert len(told) == 3 and all(len(f) == 8 for f in told)
    assert [r["generation_best"] for r in s["history"]] == [max(f) for f in told]
    lo, hi = search_bounds(spec, JETHEXA)
    replay, asked = CMAES(lo, hi, population=8, seed=0), []
    for f in told:
        asked.append(replay.ask())
        replay.tell(f)
    g, i = max(((g, i) for g in range(3) for i in range(8)), key=lambda gi: told[gi[0]][gi[1]])
    assert s["best"]["fitness"] == told[g][i]
    assert list(s["best"]["params"].values()) == pytest.approx(list(asked[g][i]), abs=1e-12)


def test_neighbours_of_lost_legs_get_relaxed_y0_bounds():
    spec = RecoverySpec(damage={"lost_legs": [1]})
    lo, hi = search_bounds(spec, JETHEXA)
    # legs 2..6; neighbours of leg 1 are 2 (opposite) and 3 (same side)
    width = {2: 0.06, 3: 0.06, 4: 0.06, 5: 0.06, 6: 0.06}
    for i, leg in enumerate([2, 3, 4, 5, 6]):
        factor = 1.4 if leg in (2, 3) else 1.0
        assert hi[i] - lo[i] == pytest.approx(width[leg] * factor)
    assert list(lo[5:10]) == [0.09] * 5 and list(hi[-2:]) == [0.05, 0.05]


def test_each_built_in_box_is_centred_on_its_robots_nominal_stance():
    """The robot owns its stance (app/robots/catalog.py), the kind its search box
    (trajectory.BUILT_IN): the paper's nominal gait is the centre of the box."""
    from app.jobs.recovery.trajectory import BUILT_IN
    from app.robots.catalog import ROBOTS

    assert set(BUILT_IN) <= set(ROBOTS)
    for name, box in BUILT_IN.items():
        robot = ROBOTS[name]
        assert sorted(box.y0) == sorted(robot.legs)
        assert all(0.5 * (lo + hi) == robot.nominal_y0(leg) for leg, (lo, hi) in box.y0.items())
        assert 0.5 * sum(box.x0) == robot.nominal_x0()
        assert box.step_length[0] <= robot.nominal_step_length <= box.step_length[1]
        assert box.step_height[0] <= robot.nominal_step_height <= box.step_height[1]


def test_a_built_in_robot_without_the_papers_box_gets_its_stances():
    """A new built-in robot needs no line in this kind: its box is scaled by its stance
    height around its nominal stance, as an uploaded robot's is."""
    import dataclasses

    from app.jobs.recovery.trajectory import search_box

    other = dataclasses.replace(JETHEXA, name="jethexa-tall", stance_height=0.12)
    box = search_box(other)
    assert box.x0 == pytest.approx((0.11 - 0.024, 0.11 + 0.024)) and box.step_length == pytest.approx((0.024, 0.06))
    assert box.y0[1] == pytest.approx((0.02 - 0.036, 0.02 + 0.036)) and sorted(box.y0) == [1, 2, 3, 4, 5, 6]
    assert search_box(JETHEXA).x0 == (0.09, 0.13)  # the paper's robot keeps the paper's box


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


# -- evidence: controls, robustness, robust search, convergence ------------------------------

def test_controls_sit_beside_the_result_at_the_same_budget(small_run):
    _, res = small_run
    s = res.summary
    names = [c["name"] for c in s["controls"]]
    assert names == ["baseline", "random_search"]
    base, rnd = s["controls"]
    assert base["metrics"] == s["baseline"]["metrics"] and base["target_met"] is False
    assert rnd["evaluations"] == 8 * 5  # the search's own budget
    assert len(s["random_search_history"]) == 5
    assert set(rnd["params"]) == set(s["best"]["params"]) and rnd["params"] != s["best"]["params"]
    assert isinstance(rnd["target_met"], bool) and "same budget" in rnd["note"]
    assert s["target"]["best_met"] is s["best"]["target_met"]


def test_robustness_block_is_a_real_re_simulation_of_the_answer(small_run):
    from app.jobs.recovery.sequences import plan_hexapod
    from app.jobs.recovery.run import sim_config, sim_model
    from app.jobs.recovery.evaluate import GaitEvaluator
    from app.jobs.recovery.cases import perturbation
    from app.sim.perturb import perturbed_model

    spec, res = small_run
    rob = res.summary["robustness"]
    names = [c["name"] for c in rob["cases"]]
    assert names == ["dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_+10pct", "payload", "rough_terrain"]
    assert rob["total"] == 7 and rob["met"] == sum(c["target_met"] for c in rob["cases"])
    nominal_y = res.summary["best"]["metrics"]["y_f_m"]
    assert rob["spread"]["y_f_m"]["nominal"] == nominal_y
    assert all(c["metrics"]["y_f_m"] != nominal_y for c in rob["cases"])
    # re-simulate one case by hand: the block holds exactly that simulation's numbers
    mspec, model = sim_model(spec, JETHEXA)
    case = perturbation("friction_0.7", JETHEXA.geometry.total_mass)
    seq = plan_hexapod([1, 6], JETHEXA.nominal_feet_xy(), JETHEXA.stance_com_xy(model, 0.10))
    ev = GaitEvaluator(JETHEXA, perturbed_model(mspec, case, model), seq, sim_config(spec))
    x = np.array(list(res.summary["best"]["params"].values()))
    m = ev.evaluate(x).metrics
    got = next(c for c in rob["cases"] if c["name"] == "friction_0.7")["metrics"]
    assert got["x_f_m"] == float(m["x_f_m"][0]) and got["yaw_f_deg"] == float(m["yaw_f_deg"][0])


def test_robust_search_scores_every_candidate_on_every_model(tmp_path):
    d = SMALL | {"search": {"population": 6, "generations": 2, "seed": 1},
                 "robust": {"models": ["friction_0.7", "payload"], "aggregate": "worst"},
                 "controls": {"random_search": False}, "robustness": {"cases": ["friction_1.3"]}}
    spec = parse_spec(d)
    assert spec.evaluations_budget == 6 * 3 * 3 + 1 + 3 + 20  # 20 held-out models
    s = run(spec, Ctx(tmp_path)).summary
    per = s["robust"]["best_per_model"]
    assert [p["name"] for p in per] == ["nominal", "friction_0.7", "payload"]
    # the search's best F is the worst of the three models' F for that gait
    assert s["history"][-1]["best"] == pytest.approx(min(p["fitness"] for p in per))
    assert per[0]["fitness"] == pytest.approx(s["best"]["fitness"])
    assert s["timing"]["evaluations"] == spec.evaluations_budget - 1  # no random-search best to re-score
    assert [c["name"] for c in s["controls"]] == ["baseline"]


def test_a_baseline_that_already_meets_the_target_is_marked(tmp_path):
    """Leg 1 lost: the nominal tripod already walks about a metre straight."""
    spec = parse_spec({"kind": "recovery", "damage": {"lost_legs": [1]}, "search": {"population": 4, "generations": 1},
                       "controls": {"random_search": False}, "robustness": {"cases": []}})
    s = run(spec, Ctx(tmp_path)).summary
    assert s["baseline"]["target_met"] is True and s["target"]["baseline_met"] is True
    assert "no recovery" in s["target"]["note"]
    assert s["controls"][0]["note"].startswith("already meets the target")
    assert s["robustness"]["cases"] == [] and s["robustness"]["held_out"]["n"] == 20  # no named case: held-out only


@pytest.mark.parametrize("patch,field", [
    ({"robust": {"models": ["friction_0.5"]}}, "robust.models.0"),
    ({"robust": {"models": []}}, "robust.models"),
    ({"robust": {"models": ["payload", "payload"]}}, "robust.models"),
    ({"robust": {"models": ["payload"], "aggregate": "best"}}, "robust.aggregate"),
    ({"robustness": {"cases": ["dt_eighth"]}}, "robustness.cases.0"),
    ({"controls": {"random_search": "yes"}}, "controls.random_search"),
    ({"sim": {"timestep_s": 0.02}}, "sim.timestep_s"),
])
def test_bad_evidence_specs_name_the_field(patch, field):
    with pytest.raises(SpecError) as e:
        parse_spec(SMALL | patch)
    assert [x["field"] for x in e.value.errors][0] == field


def test_the_built_in_hexapod_takes_damage_by_name_and_numbers_are_its_spelling(small_run, tmp_path):
    """One vocabulary (app/robots/damage.py) for the built-in robot too: legs lost by name give
    the very numbers legs lost by number give (the numbers are the paper's spelling), and the
    types the paper's spelling lacks (passive, stiff joints, shortened legs) reach the model."""
    import mujoco

    from app.jobs.recovery.run import damage_spec, sim_model

    spec, res = small_run
    named = parse_spec({k: v for k, v in SMALL.items() if k != "damage"}
                       | {"robot_damage": {"lost_legs": ["leg6", "leg1"]}})
    assert named.damage.lost_legs == [1, 6] and sorted(damage_spec(named).lost_legs) == damage_spec(spec).lost_legs
    again = run(named, Ctx(tmp_path))
    moved = {"damage", "timing"}  # the summary says the damage as given; every number is the same
    assert {k: v for k, v in again.summary.items() if k not in moved} == {
        k: v for k, v in res.summary.items() if k not in moved}
    assert parse_spec(named.model_dump(mode="json")) == named  # a stored spec reads back

    more = parse_spec({"kind": "recovery", "robot_damage": {
        "lost_legs": ["leg1", "leg6"], "passive_joints": [{"leg": "leg3", "joint": "leg3_tibia"}],
        "stiff_joints": [{"leg": "leg2", "joint": "leg2_femur", "friction": 0.3}]}})
    _, model = sim_model(more, JETHEXA)
    actuated = {model.joint(int(model.actuator_trnid[i, 0])).name for i in range(model.nu)}
    assert "leg3_tibia" not in actuated and "leg2_femur" in actuated and len(actuated) == 11
    assert model.joint("leg2_femur").frictionloss[0] == 0.3 and model.joint("leg4_femur").frictionloss[0] == 0.0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "leg3_tibia") >= 0  # passive: still there


@pytest.mark.parametrize("damage, field", [
    ({"robot_damage": {"lost_legs": ["leg9"]}}, "robot_damage"),
    ({"robot_damage": {"passive_joints": [{"leg": "leg2", "joint": "leg3_femur"}]}}, "robot_damage"),
    ({"robot_damage": {"lost_legs": ["leg1", "leg3"]}}, "robot_damage.lost_legs"),
    ({"damage": {"lost_legs": [2, 5]}, "robot_damage": {"lost_legs": ["leg1", "leg6"]}}, "damage"),
])
def test_a_built_in_robots_damage_by_name_is_checked_against_its_map(damage, field):
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "recovery"} | damage)
    assert f"{field}:" in str(e.value)


def test_any_registered_optimizer_that_maximises_runs_the_search(small_run, tmp_path):
    """The optimiser is a name the registry checks (app/optim/registry.py): PSO runs the
    recovery search through the same loop (another answer than DE's from the same seed);
    the GA (it minimises) and unknown names are refused naming search.optimizer."""
    spec = parse_spec(SMALL | {"search": SMALL["search"] | {"optimizer": "pso"}})
    res = run(spec, Ctx(tmp_path))
    assert res.summary["search"]["generations_run"] == SMALL["search"]["generations"] + 1
    assert np.isfinite(res.summary["best"]["fitness"]) and len(res.summary["best"]["params"]) == 10
    assert res.summary["best"]["params"] != small_run[1].summary["best"]["params"]
    for bad, why in (("ga", "minimises"), ("nelder_mead", "unknown")):
        with pytest.raises(SpecError) as e:
            parse_spec(SMALL | {"search": SMALL["search"] | {"optimizer": bad}})
        assert "search.optimizer" in str(e.value) and why in str(e.value)

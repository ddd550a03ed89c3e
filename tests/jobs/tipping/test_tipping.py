"""The tipping job end to end on the real simulator (paper 002), with its evidence."""

import json

import numpy as np
import pytest

from app.jobs.base import Cancelled, SpecError
from app.jobs.registry import parse_spec
from app.jobs.tipping.run import run, sweep_table
from app.jobs.tipping.spec import TippingSpec


class Ctx:
    def __init__(self, tmp_path, checkpoint=None, cancel=False, cancel_after=None):
        self.artifact_dir = tmp_path
        self.checkpoints, self.progress_calls = [], []
        self._initial, self._cancel, self._cancel_after = checkpoint, cancel, cancel_after

    def progress(self, done, total, info):
        self.progress_calls.append((done, total, info))

    def save_checkpoint(self, state):
        self.checkpoints.append(json.loads(json.dumps(state)))

    def load_checkpoint(self):
        return self._initial

    def is_cancelled(self):
        return self._cancel or (self._cancel_after is not None and len(self.progress_calls) >= self._cancel_after)


def test_paper_defaults_and_budget_formula():
    s = parse_spec({"kind": "tipping"})
    assert isinstance(s, TippingSpec) and s.robot == "heavy_hexapod" and s.scenario.type == "tilt"
    assert s.detector.threshold_deg == 20.0 and s.recovery.enabled and s.recovery.safety_margin == 0.9
    assert s.scenario.resolved_downhill() == 180.0  # y ccw: climbing, tips backward
    assert s.scenario.max_tilt_deg == 40.0 and s.scenario.rate_deg_s == 10.0  # fixed, never the robot's tip angle
    assert s.recovery.stance_control == "force" and s.recovery.swing_timing == "eq15"
    assert s.sim.timestep_s == 0.001
    # 1 + 1 runs, 3 controls, 7 robustness re-runs, 2 x (2 + ceil(log2(50 / 1))) band probes
    assert s.evaluations_budget == 2 + 3 + 7 + 2 * 8
    assert parse_spec({"kind": "tipping", "sweep": {"enabled": True}}).evaluations_budget == 28 + 2 * 12 * 2
    assert parse_spec({"kind": "tipping", "recovery": {"enabled": False}}).evaluations_budget == 1
    assert parse_spec({"kind": "tipping", "scenario": {"type": "cliff"}}).evaluations_budget == 2 + 3 + 7  # no band


@pytest.mark.parametrize("bad, field", [
    ({"scenario": {"type": "tilt", "stance": [1, 2, 3]}}, "stance"),
    ({"scenario": {"type": "tilt", "axis": "z"}}, "axis"),
    ({"scenario": {"type": "tilt", "axis": "x", "downhill_deg": 10}}, "scenario"),
    ({"scenario": {"type": "tilt", "overshoot_deg": 4.0}}, "overshoot_deg"),  # gone: the motion ignores the robot
    ({"scenario": {"type": "tilt", "max_tilt_deg": None}}, "max_tilt_deg"),
    ({"scenario": {"type": "tilt", "max_tilt_deg": 75.0}}, "max_tilt_deg"),
    ({"scenario": {"type": "tilt", "rate_deg_s": "10"}}, "rate_deg_s"),
    ({"scenario": {"type": "cliff", "duty_factor": 0.4}}, "duty_factor"),
    ({"scenario": {"type": "stairs"}}, "scenario"),
    ({"detector": {"threshold_deg": -1}}, "detector.threshold_deg"),
    ({"recovery": {"safety_margin": 1.2}}, "recovery.safety_margin"),
    ({"recovery": {"swing_min_s": 2.0, "swing_max_s": 1.0}}, "recovery"),
    ({"recovery": {"stance_control": "torque"}}, "recovery.stance_control"),
    ({"recovery": {"swing_timing": "paper"}}, "recovery.swing_timing"),
    ({"recovery": {"compliance": 0.0}}, "recovery.compliance"),
    ({"recovery": {"force_tracking_gain": 1e-6}}, "force_tracking_gain"),
    ({"sim": {"control_dt": 0.0205}}, "sim"),
    ({"sim": {"timestep_s": 0.01}}, "sim.timestep_s"),
    ({"sim": {"duration_s": 500}}, "sim.duration_s"),
    ({"evidence": {"band_tolerance_deg": 0.0}}, "evidence.band_tolerance_deg"),
    ({"evidence": {"band_min_deg": 50.0, "band_max_deg": 45.0}}, "evidence"),
    ({"evidence": {"target_margin_deg": float("nan")}}, "evidence.target_margin_deg"),
    ({"sweep": {"directions": 0}}, "sweep.directions"),
    ({"scenario": {"type": "cliff"}, "sweep": {"enabled": True}}, "sweep"),
    ({"robot": "jethexa"}, "robot"),
    ({"bogus": 1}, "bogus"),
])
def test_bad_specs_name_the_field(bad, field):
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "tipping", **bad})
    assert any(field in err["field"] or field in err["message"] for err in e.value.errors), e.value.errors


# A short hold and a coarse band keep this under a minute; every number is still a real run.
QUICK = {"kind": "tipping", "scenario": {"type": "tilt", "axis": "y", "direction": "ccw", "stance": [1, 3, 5],
                                         "hold_s": 0.5},
         "sim": {"duration_s": 8.0}, "evidence": {"band_min_deg": 30.0, "band_max_deg": 60.0, "band_tolerance_deg": 10.0}}


@pytest.fixture(scope="module")
def climbing(tmp_path_factory):
    spec = parse_spec(QUICK)
    ctx = Ctx(tmp_path_factory.mktemp("tip"))
    return spec, run(spec, ctx), ctx


def test_tilt_tips_without_recovery_and_stays_up_with_it(climbing):
    """Paper Sec. 5.2, climbing with legs 1, 3, 5: the platform turns to a fixed 40 deg; the
    judgment fires on edge a35, leg 6 catches the robot after the Eq. 15 time."""
    spec, res, _ = climbing
    s = res.summary
    base, rec = s["runs"]["no_recovery"], s["runs"]["recovery"]
    assert base["tipped"] and not rec["tipped"] and s["recovered"]
    assert base["static_tip_deg"] < spec.scenario.max_tilt_deg == base["max_tilt_deg"]
    assert s["tipping_edge"] == "a35" and s["adjustment_leg"] == 6
    assert 0 < rec["margin_at_detection_deg"] < 20
    assert s["swing_s"] == pytest.approx(s["time_to_tip_s"]) and 0.5 < s["time_to_tip_s"] < 3.0
    assert s["margin_after_landing_deg"] > 0
    x, y, _ = s["foothold_body_m"]
    assert x < -2.0 and y < -1.9  # behind and right of the body (Fig. 3)
    tr = res.traces["recovery"]
    assert tr["foot_f_n"].shape == (len(tr["time_s"]), 6, 3) and tr["qp_f_n"].shape == tr["foot_f_n"].shape
    assert np.all(np.diff(tr["time_s"]) == pytest.approx(0.02)) and tr["qpos"].shape[0] == len(tr["time_s"])
    json.dumps(s)  # no NaN or numpy leaks into the summary


def test_controls_robustness_and_band_are_real_reruns(climbing):
    spec, res, ctx = climbing
    s = res.summary
    ctl = {c["name"]: c for c in s["controls"]}
    assert set(ctl) == {"no_recovery", "no_qp", "position_stance", "fixed_swing"}
    assert ctl["no_recovery"]["metrics"]["tipped"] and ctl["no_recovery"]["target_met"] is False
    assert ctl["fixed_swing"]["metrics"]["swing_s"] == 1.5 != s["swing_s"]
    for c in s["controls"]:
        assert c["evaluations"] == 1 and c["label"] and isinstance(c["target_met"], bool)
    rob = s["robustness"]
    names = [c["name"] for c in rob["cases"]]
    assert names == ["dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_+10pct", "mass_-10pct", "payload"]
    assert rob["total"] == 7 and rob["met"] == sum(c["target_met"] for c in rob["cases"])
    assert "margin_after_landing_deg" in rob["spread"]
    # Re-simulated, not copied: the perturbed runs' numbers are not all the nominal's.
    after = {c["name"]: c["metrics"]["margin_after_landing_deg"] for c in rob["cases"]}
    assert len({round(v, 6) for v in after.values() if v is not None} | {round(s["margin_after_landing_deg"], 6)}) > 3
    assert s["convergence"]["step_halved"]["ok"]
    band = s["band"]
    w, wo = band["with_recovery"], band["without_recovery"]
    assert wo["max_upright_deg"] < w["max_upright_deg"] and band["gain_deg"] > 0
    assert wo["min_tipped_deg"] - wo["max_upright_deg"] <= 10.0
    # Every simulation is counted once it has run, then the job reports itself done; the
    # budget holds all of them.
    assert res.evaluations == spec.evaluations_budget == len(ctx.progress_calls) - 1
    assert all(t == spec.evaluations_budget for _, t, _ in ctx.progress_calls)
    assert [d for d, _, _ in ctx.progress_calls] == list(range(1, res.evaluations + 1)) + [res.evaluations]
    assert [i["phase"] for _, _, i in ctx.progress_calls] == (["runs"] * 2 + ["controls"] * 3 + ["robustness"] * 7
                                                             + ["band"] * 8 + ["done"])


def test_cancel_is_checked_between_evidence_runs(tmp_path):
    spec = parse_spec(QUICK)
    ctx = Ctx(tmp_path, cancel_after=4)  # after the two runs and two controls
    with pytest.raises(Cancelled):
        run(spec, ctx)
    assert len(ctx.progress_calls) == 4
    assert set(ctx.checkpoints[-1]["controls"]["units"]) == {"control:no_qp", "control:position_stance"}


def test_cliff_walk_margin_band_then_detection(tmp_path):
    """Sec. 5.1: on flat ground the tripod gait keeps the margin in a band well above the
    threshold; once leg 4 steps into the void the margin drops below it."""
    spec = parse_spec({"kind": "tipping", "scenario": {"type": "cliff"}, "recovery": {"enabled": False},
                       "sim": {"duration_s": 23.0}})
    res = run(spec, Ctx(tmp_path))
    tr = res.traces["no_recovery"]
    t, m = tr["time_s"], tr["fasm_deg"]
    flat = (t > 3.5) & (t < 20.0)
    assert m[flat].min() > 22.0 and m[flat].max() > 45.0  # paper: about 21-51 deg
    first = res.summary["runs"]["no_recovery"]["first_below_threshold_s"]
    assert first is not None and 20.5 < first < 23.0
    assert tr["com_m"][-1, 0] > 2.0  # it walked
    assert res.evaluations == spec.evaluations_budget == 1


def test_sweep_table_and_checkpointed_resume(tmp_path):
    rows = [{"downhill_deg": 0.0, "stance": "135", "recovery": 0, "tipped": 1},
            {"downhill_deg": 0.0, "stance": "135", "recovery": 1, "tipped": 0},
            {"downhill_deg": 0.0, "stance": "246", "recovery": 0, "tipped": 1},
            {"downhill_deg": 0.0, "stance": "246", "recovery": 1, "tipped": 1},
            {"downhill_deg": 180.0, "stance": "135", "recovery": 0, "tipped": 0},
            {"downhill_deg": 180.0, "stance": "135", "recovery": 1, "tipped": 0}]
    sw = sweep_table(rows, 2)
    assert sw["directions_deg"] == [0.0, 180.0]
    assert sw["success_rate"] == [0.5, 1.0] and sw["tip_rate_without_recovery"] == [1.0, 0.0]
    assert sw["recovered_rate"] == [0.5, 0.0]
    assert sw["overall_success_rate"] == 0.75
    # A run that restarts from a checkpoint with the sweep done skips straight to the table.
    spec = parse_spec({"kind": "tipping", "sweep": {"enabled": True, "directions": 2, "stances": [[1, 3, 5]]},
                       "recovery": {"enabled": False}, "sim": {"duration_s": 2.0}})
    done = [{"run": i, "downhill_deg": 180.0 * (i // 2), "stance": "135", "recovery": i % 2, "tipped": 1 - i % 2,
             "sim_steps": 0} for i in range(4)]
    ctx = Ctx(tmp_path, checkpoint={"sweep": {"rows": done, "wall_s": 1.0}})
    res = run(spec, ctx)
    assert res.summary["sweep"]["success_rate"] == [1.0, 1.0] and res.summary["sweep"]["recovered_rate"] == [1.0, 1.0]
    assert res.summary["timing"]["wall_s"] > 1.0
    assert res.evaluations == spec.evaluations_budget == 5
    with pytest.raises(Cancelled):
        run(spec, Ctx(tmp_path, cancel=True))

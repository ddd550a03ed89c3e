"""The tipping job end to end on the real simulator (paper 002)."""

import json
import math

import numpy as np
import pytest

from app.jobs.base import Cancelled, SpecError
from app.jobs.registry import KINDS, parse_spec
from app.jobs.tipping.run import run, sweep_table
from app.jobs.tipping.spec import TippingSpec


class Ctx:
    def __init__(self, tmp_path, checkpoint=None, cancel=False):
        self.artifact_dir = tmp_path
        self.checkpoints, self.progress_calls = [], []
        self._initial, self._cancel = checkpoint, cancel

    def progress(self, done, total, info):
        self.progress_calls.append((done, total, info))

    def save_checkpoint(self, state):
        self.checkpoints.append(json.loads(json.dumps(state)))

    def load_checkpoint(self):
        return self._initial

    def is_cancelled(self):
        return self._cancel


def test_registered_with_paper_defaults():
    assert KINDS["tipping"].Spec is TippingSpec
    s = parse_spec({"kind": "tipping"})
    assert s.robot == "heavy_hexapod" and s.scenario.type == "tilt"
    assert s.detector.threshold_deg == 20.0 and s.recovery.enabled and s.recovery.safety_margin == 0.9
    assert s.scenario.resolved_downhill() == 180.0  # y ccw: climbing, tips backward
    assert s.evaluations_budget == 2
    assert parse_spec({"kind": "tipping", "sweep": {"enabled": True}}).evaluations_budget == 2 + 2 * 12 * 2


@pytest.mark.parametrize("bad, field", [
    ({"scenario": {"type": "tilt", "stance": [1, 2, 3]}}, "stance"),
    ({"scenario": {"type": "tilt", "axis": "z"}}, "axis"),
    ({"scenario": {"type": "tilt", "axis": "x", "downhill_deg": 10}}, "scenario"),
    ({"scenario": {"type": "cliff", "duty_factor": 0.4}}, "duty_factor"),
    ({"scenario": {"type": "stairs"}}, "scenario"),
    ({"detector": {"threshold_deg": -1}}, "detector.threshold_deg"),
    ({"recovery": {"safety_margin": 1.2}}, "recovery.safety_margin"),
    ({"recovery": {"swing_min_s": 2.0, "swing_max_s": 1.0}}, "recovery"),
    ({"sim": {"control_dt": 0.003}}, "sim.control_dt"),
    ({"sim": {"duration_s": 500}}, "sim.duration_s"),
    ({"sweep": {"directions": 0}}, "sweep.directions"),
    ({"scenario": {"type": "cliff"}, "sweep": {"enabled": True}}, "sweep"),
    ({"robot": "jethexa"}, "robot"),
    ({"bogus": 1}, "bogus"),
])
def test_bad_specs_name_the_field(bad, field):
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "tipping", **bad})
    assert any(field in err["field"] or field in err["message"] for err in e.value.errors), e.value.errors


def test_tilt_tips_without_recovery_and_stays_up_with_it(tmp_path):
    """Paper Sec. 5.2, climbing a steep slope with legs 1, 3, 5 in stance: the judgment fires
    on edge a35, leg 6 catches the robot, the margin climbs back above the threshold."""
    spec = parse_spec({"kind": "tipping", "scenario": {"type": "tilt", "axis": "y", "direction": "ccw",
                                                       "stance": [1, 3, 5]}, "sim": {"duration_s": 22.0}})
    res = run(spec, Ctx(tmp_path))
    s = res.summary
    base, rec = s["runs"]["no_recovery"], s["runs"]["recovery"]
    assert base["tipped"] and base["final_body_tilt_deg"] > 30
    assert not rec["tipped"] and rec["final_body_tilt_deg"] < 5
    assert s["recovered"]
    assert s["tipping_edge"] == "a35" and s["adjustment_leg"] == 6
    # Detected before the margin reaches zero, and the swing lands before the estimated tip.
    assert 0 < rec["margin_at_detection_deg"] < 20
    t, m = res.traces["no_recovery"]["time_s"], res.traces["no_recovery"]["fasm_deg"]
    assert s["detection_time_s"] < t[np.argmax((m <= 0) & (t > 1))]
    assert s["adjustment_time_s"] <= s["time_to_tip_s"]
    assert s["margin_after_landing_deg"] > 20 > s["margin_before_landing_deg"]
    # The foothold is outside the tipping edge: behind and right of the body (Fig. 3).
    x, y, _ = s["foothold_body_m"]
    assert x < -2.0 and y < -1.9
    # Traces: per-step margins beside the SSM/NESM, foot forces of all six legs, replayable qpos.
    tr = res.traces["recovery"]
    assert tr["fasm_deg"].shape == tr["time_s"].shape and tr["foot_fz_n"].shape == (len(tr["time_s"]), 6)
    assert np.all(np.diff(tr["time_s"]) == pytest.approx(0.02))
    assert tr["qpos"].shape[0] == len(tr["time_s"]) and np.isfinite(tr["ssm_m"]).all()
    assert tr["qp_stability"].any()  # the QP ran with the FASM pyramid after the landing
    json.dumps(s)  # no NaN or numpy leaks into the summary


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
    res = run(spec, Ctx(tmp_path, checkpoint={"rows": done, "wall_s": 1.0}))
    assert res.summary["sweep"]["success_rate"] == [1.0, 1.0] and res.summary["sweep"]["recovered_rate"] == [1.0, 1.0]
    assert res.summary["timing"]["wall_s"] > 1.0
    with pytest.raises(Cancelled):
        run(spec, Ctx(tmp_path, cancel=True))

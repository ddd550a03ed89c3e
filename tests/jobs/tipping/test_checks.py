"""The friction, timing, convergence and robustness ledgers behind docs/tipping.md's findings
2 and 3, its convergence rule and its robustness paragraph: the plans, the resume (a re-run
skips what the file holds) and the rendering from fixture rows (no simulation here; the
runs are replaced by fakes that read the job spec they are given)."""

from __future__ import annotations

import pytest

from app.jobs.tipping.reproduce import checks
from app.jobs.tipping.reproduce.checks import (CASES, ConvergenceParams, FrictionParams, RobustnessParams, TimingParams,
                                     convergence, friction, robustness, timing)
from app.jobs.tipping.reproduce.checks_docs import render_convergence, render_friction, render_robustness, render_timing
from app.jobs.tipping.spec import TippingSpec


def _out(tipped=False, margin=15.0, det=5.0, ts=1.7, swing=1.7, slip=0.02, demand=0.9, **kw) -> dict:
    return {"tipped": tipped, "tipped_at_s": 9.0 if tipped else None, "final_margin_deg": None if tipped else 14.0,
            "max_slip_m": slip, "friction_demand": None if tipped else demand, "detection_time_s": det, "leg": 6,
            "time_to_tip_s": ts, "swing_s": swing, "adjustment_time_s": swing, "margin_after_landing_deg": margin,
            "load_after": 1.0, "cores": 2} | kw


def _spec(job: dict) -> TippingSpec:
    return TippingSpec.model_validate(job)


def test_friction_plan_resume_and_rendering(tmp_path, monkeypatch):
    calls = []

    def fake(job):
        s = _spec(job)
        calls.append(job)
        mu, mode = s.sim.friction, ("no_qp" if not s.recovery.qp else s.recovery.stance_control)
        if mu < 0.84:
            return _out(tipped=True, slip=2.0, qp_force_error_pct=None, stance_load_pct={})
        err = {"force": 4.0 if s.scenario.downhill_deg != 90.0 else 7.0, "position": 20.0}.get(mode)
        return _out(margin=16.0 + (0.2 if mode == "position" else 0.0), slip=0.03 if mode == "force" else 0.01,
                    demand=1.2 if mode == "position" else 0.87, qp_force_error_pct=err,
                    stance_load_pct={"1": 20.0, "3": 40.0, "5": 0.0 if mode == "position" else 10.0, "6": 30.0})

    monkeypatch.setattr(checks, "friction_run", fake)
    p = FrictionParams(frictions="1.5,0.9,0.8", json_out=tmp_path / "f.json")
    text = friction(p, lambda m: None)
    assert len(calls) == 3 * 3 * 3
    assert {_spec(j).recovery.stance_control for j in calls} == {"force", "position"}
    friction(p, lambda m: None)
    assert len(calls) == 27  # every run was in the file: nothing re-run
    assert "force-controlled 4.0 % of the weight climbing and descending, 7.0 % lateral; position servos 20.0 %" in text
    assert "At friction 0.9: upright in 9 of 9 runs" in text
    assert "at friction 0.8: upright in 0 of 9 runs" in text
    assert "climbing leg 5 at 0 %" in text
    assert "decides upright or tipped in 0 of 9 (friction, case) pairs" in text
    assert "worst foot, force-controlled, climbing and descending (%): record 3.6-4.3, here 4.0 (differs)" in text
    assert "paired over the (friction, case) pairs where both caught a leg: +0.00 deg" in text and "n = 9: **not shown**" in text
    with pytest.raises(ValueError, match="cases must be among"):
        FrictionParams(cases="climbing,upside-down")


def test_timing_fall_from_the_judgment_and_the_comparison(tmp_path, monkeypatch):
    def fake(job):
        s = _spec(job)
        rate, fixed = s.scenario.rate_deg_s, s.recovery.swing_timing == "fixed"
        if not s.recovery.enabled:
            return _out(tipped=True, det=None, ts=None, swing=None, margin=None, margin_zero_s=5.0 + 10.0 / rate)
        ts = 8.0 / rate
        return _out(det=5.0, ts=ts, swing=1.5 if fixed else ts, margin=(20.0 if fixed else 16.0) - rate / 10.0,
                    kappa=0.8, platform_at_detection="constant rate")

    monkeypatch.setattr(checks, "timing_run", fake)
    text = timing(TimingParams(rates_deg_s="10,20", json_out=tmp_path / "t.json"), lambda m: None)
    # 10 deg/s: t_s = 0.8, t_s / kappa = 1.0 against the fall 15 - 5... = 1.0 s
    assert "| 10 | climbing | 0.80 | 1.00 | 1.00 | 5.00 (constant rate) | 0.80 / 1.50 | yes / yes | 15.0 / 19.0 |" in text
    assert "(the ratio 1.00); judged while the platform is constant rate, 1.00 s after its start-up ramp ended" in text
    assert "(the fixed swing higher in 3 of 3)" in text and "the Eq. 15 swing in 6 of 6" in text
    assert "t_s at 10 deg/s (s): record 1.71 / 1.82 / 1.52, here 0.80 / 0.80 / 0.80 (differs)" in text
    assert "paired over the 6 (rate, case) runs: -4.00 deg [-4.00, -4.00] (95 %)" in text
    assert "n = 6: **the fixed swing better (shown)**" in text


def test_convergence_pairs_each_step_with_its_half(tmp_path, monkeypatch):
    def fake(job):
        s = _spec(job)
        step = s.sim.timestep_s * 1e3
        tipped = step == 2.0 and s.scenario.downhill_deg == 270.0
        return _out(tipped=tipped, margin=16.0 + step, ts=1.7 + 0.01 * step)

    monkeypatch.setattr(checks, "plain_run", fake)
    p = ConvergenceParams(directions="180,270", json_out=tmp_path / "c.json")
    text = convergence(p, lambda m: None)
    assert "| 2 vs 1 | 270 | yes / no |" in text and "| 1 vs 0.5 | 180 | no / no | 17.00 / 16.50 |" in text
    assert "- 2 ms against 1 ms: within tolerance in 1 of 2 directions" in text
    assert "moved up to 1.00 deg (margin after landing)" in text
    assert "- 1 ms against 0.5 ms: within tolerance in 2 of 2 directions" in text and "0.50 deg" in text
    with pytest.raises(ValueError):
        ConvergenceParams(steps_ms="0.25")


def test_robustness_rate_and_the_paper_bar(tmp_path, monkeypatch):
    def evidence(what, name, job):
        return _out(margin=-1.0 if name == "payload" else 15.0, ts=None if name == "payload" else 1.7,
                    swing=4.0 if name == "payload" else 1.7)

    monkeypatch.setattr(checks, "cliff_evidence", evidence)
    monkeypatch.setattr(checks, "nominal_run", lambda job: _out(platform_tilt_at_landing_deg=[31.8, 36.6]))
    text = robustness(RobustnessParams(cases="climbing", json_out=tmp_path / "r.json"), lambda m: None)
    assert "- climbing: the target met in 6/7 = 0.86 [0.42, 1.00] (Clopper-Pearson 95 %)" in text
    assert "margin after landing -1.0-15.0 deg (lowest: payload)" in text
    assert "Eq. 15 not finite at the judgment in payload (swing 4.00 s, upright)" in text
    assert "is met by 0 of the 7 re-runs" in text and "climbing 31.8 / 36.6" in text
    assert "climbing: met: record 7/7, here 6/7 (differs)" in text
    assert set(CASES) == {"climbing", "descending", "lateral"}


def test_missing_data():
    for render in (render_friction, render_timing, render_convergence, render_robustness):
        assert render([None]).startswith("*No data yet")

"""The sweep and cliff ledgers behind docs/tipping.md's "Sweep" and "Cliff" sections: their
plans, the resume (a re-run skips what the file holds) and the rendering of the tables,
counts and paired comparisons from a small fixture of rows (no simulation here)."""

from __future__ import annotations

import pytest

from app.jobs.ledger import Ledger
from app.jobs.tipping.reproduce import reruns
from app.jobs.tipping.reproduce.reruns import SweepParams, _cliff_plan, _sweep_plan, sweep, sweep_job
from app.jobs.tipping.reproduce.reruns_docs import render_cliff, render_sweep_tilt, sweep_grid
from app.jobs.tipping.spec import TippingSpec


def _row(psi: float, stance: str, recovery: bool, tipped: bool, margin: float | None = 10.0, leg: int = 4) -> dict:
    return {"run": 0, "downhill_deg": psi, "stance": stance, "recovery": int(recovery), "tipped": int(tipped),
            "tipped_at_s": 12.0 if tipped else None, "static_tip_deg": 36.0, "detect_time_s": 5.0 if recovery else None,
            "edge": "a51" if recovery else "", "leg": leg if recovery else 0,
            "margin_after_deg": margin if recovery else None, "final_margin_deg": 20.0, "sim_steps": 1}


def _ledger(tmp_path, results: dict[str, dict]) -> dict:
    led = Ledger(tmp_path / "l.json", "tipping-sweep", "cmd", {}, reruns.SCIENCE)
    for name, res in results.items():
        led.run(name, {"name": name}, 0, lambda res=res: res | {"load_after": 1.5, "cores": 2})
    return led.data


# Two directions at 40 deg: without recovery 3 of 4 tip; with the QP all 4 stay up, one with
# a margin after landing below 0; without the QP the 2-4-6 run at 180 tips.
FIXTURE = {
    "40:no_recovery:0": {"rows": [_row(0, "135", False, True), _row(0, "246", False, True)]},
    "40:qp:0": {"rows": [_row(0, "135", True, False), _row(0, "246", True, False, margin=-90.0)]},
    "40:no_qp:0": {"rows": [_row(0, "135", True, False), _row(0, "246", True, False)]},
    "40:no_recovery:180": {"rows": [_row(180, "135", False, False), _row(180, "246", False, True)]},
    "40:qp:180": {"rows": [_row(180, "135", True, False), _row(180, "246", True, False)]},
    "40:no_qp:180": {"rows": [_row(180, "135", True, False), _row(180, "246", True, True)]},
}


def _trace(tipped: bool, lands: tuple[float, float]) -> dict:
    adj = [{"detect_time_s": 4.5, "leg": leg, "land_time_s": t, "margin_before_landing_deg": 0.0,
            "margin_after_landing_deg": 2.0} for leg, t in zip((1, 3), lands)]
    return {"tipped": tipped, "tipped_at_s": 10.5 if tipped else None, "adjustments": adj,
            "samples": [{"time_s": 8.0 + k, "body_off_platform_deg": 1.0 + (3 * k if tipped else 0), "margin_deg": -0.01}
                        for k in range(8)]}


TRACES = {"trace:40:qp:0:246": _trace(True, (8.0, 12.0)), "trace:40:no_qp:0:246": _trace(False, (8.0, 12.0))}


def test_sweep_rendering_counts_and_paired_comparisons(tmp_path):
    data = _ledger(tmp_path, FIXTURE | TRACES)
    grid = sweep_grid(data)
    assert set(grid) == {40.0} and set(grid[40.0]) == {"no_recovery", "qp", "no_qp"}
    text = render_sweep_tilt(40.0, [data])
    assert "| 0 | yes / yes | yes / yes | 4 (a51) / 4 (a51) | 10.0 / -90.0 | yes / yes |" in text
    assert "| 180 | no / yes | yes / yes | 4 (a51) / 4 (a51) | 10.0 / 10.0 | yes / no |" in text
    assert "tips without recovery in 3/4 = 0.75 [0.19, 0.99] of the runs" in text
    assert "stays upright with recovery in 4/4 = 1.00 [0.40, 1.00]; without the QP in 3/4 = 0.75" in text
    # paired, 4 pairs: the exact signed-rank test cannot reject, so nothing is shown
    assert "upright only with recovery in 3 (0 with 1-3-5, 0 with 2-4-6, 180 with 2-4-6)" in text
    assert "only without the QP in 0 (none), only with the QP in 1 (180 with 2-4-6)" in text
    assert text.count("**not shown**") == 2
    assert "below 0 (a miss of the job's target): 1 (0 with 2-4-6)" in text
    assert "the same in 3 of 4 mirrored pairs" in text  # 0/135 vs 0/246 and 180/135 vs 180/246
    assert "without recovery: 2 directions" in text
    # the traced run: samples up to 1 s after it tips, "-0.0" written as 0.0
    assert ("with the QP: judged at 4.50 s, leg 1 lands at 8.00 s (margin 2.0 deg 0.5 s later); body off the platform / "
            "margin (deg) at 8.00 s and every second after: 1.0 / 0.0, 4.0 / 0.0, 7.0 / 0.0, 10.0 / 0.0; it tips at "
            "10.50 s, before the second adjustment (leg 3) lands at 12.00 s. Without the QP:") in text
    assert "the second adjustment (leg 3) lands at 12.00 s (margin 2.0 deg 0.5 s later); it stays upright." in text
    # against issue 12's record (the fixture's rows are not its rows)
    assert ("0 of the 2 directions here (the record has 12) the same in every cell of the record's columns "
            "(differing: 0, 180); tip without recovery: 3 of 4 here, 12 of 24 in the record") in text
    assert render_sweep_tilt(48.0, [data]).startswith("*No 48 deg rows yet")


def test_sweep_plan_shares_the_runs_without_recovery_and_resumes(tmp_path, monkeypatch):
    plan = _sweep_plan(SweepParams(tilts_deg="40", variants="qp,no_qp", extra="48:posture_1hz", traces="48:60:246"))
    names = [n for n, _, _ in plan]
    assert names[:3] == ["40:no_recovery:0", "40:qp:0", "40:no_qp:0"] and len(names) == 12 * 3 + 12 + 2
    assert names[-3:] == ["48:posture_1hz:330", "trace:48:qp:60:246", "trace:48:no_qp:60:246"]
    assert not any(n.startswith("48:no_recovery") for n in names)
    trace = TippingSpec.model_validate(plan[-1][1]["job"])
    assert trace.scenario.build().stance == (2, 4, 6) and trace.scenario.downhill_deg == 60.0
    assert trace.scenario.max_tilt_deg == 48.0 and trace.recovery.qp is False and not trace.sweep.enabled
    for _, spec, _ in plan[:-2]:
        s = TippingSpec.model_validate(spec["job"])
        assert s.sweep.enabled and not (s.evidence.controls or s.evidence.robustness or s.evidence.band)
    assert TippingSpec.model_validate(sweep_job(48.0, "no_qp")).recovery.qp is False
    assert TippingSpec.model_validate(sweep_job(40.0, "qp", recovery=False)).recovery.enabled is False
    with pytest.raises(ValueError, match="unknown sweep variant"):
        _sweep_plan(SweepParams(variants="qp,bogus"))
    calls = []

    def fake(job, psi):
        calls.append(psi)
        rec = job.get("recovery", {}).get("enabled", True)
        return {"rows": [_row(psi, s, rec, not rec) for s in ("135", "246")], "load_after": 1.0, "cores": 2}

    monkeypatch.setattr(reruns, "sweep_direction", fake)
    p = SweepParams(tilts_deg="40", variants="qp", extra="", traces="", json_out=tmp_path / "s.json")
    text = sweep(p, lambda m: None)
    assert len(calls) == 24 and "tips without recovery in 24/24" in text
    sweep(p, lambda m: None)
    assert len(calls) == 24  # every direction was in the file: nothing re-run


def _cliff_result(tipped: bool, leg: int | None, t_s: float | None, after: float | None) -> dict:
    return {"tipped": tipped, "tipped_at_s": 23.0 if tipped else None, "detection_time_s": None if leg is None else 21.4,
            "leg": leg, "swing_s": None if leg is None else 4.0, "time_to_tip_s": t_s, "margin_after_landing_deg": after,
            "final_margin_deg": None if tipped else 47.0, "max_slip_m": 0.1}


def test_cliff_rendering(tmp_path):
    assert len(_cliff_plan()) == 12
    run = {"first_below_threshold_s": 21.38, "min_margin_deg": -0.8, "final_body_tilt_deg": 0.1,
           "flat_margin_deg": [24.5, 48.4], "flat_window_s": [3.0, 20.38], "tipping_edge": "a62",
           "foothold_body_m": [-2.42, 2.4, -1.73], "adjustment_time_s": 5.0}
    data = _ledger(tmp_path, {"no_recovery": run | _cliff_result(True, None, None, None),
                              "recovery": run | _cliff_result(False, 3, None, 47.5),
                              "control:no_qp": _cliff_result(False, 3, None, 48.3),
                              "robust:dt_half": _cliff_result(False, 3, 0.1, 47.6),
                              "robust:payload": _cliff_result(False, 3, None, -1.0)})
    text = render_cliff([data])
    assert "| no recovery | no | 23.00 | - | - |" in text and "| recovery | yes | - | 21.40 | 3 | 4.00 | - | 47.5 |" in text
    assert "the margin cycles in 24.5-48.4 deg" in text and "leg 3 (edge a62) is placed at (-2.42, 2.40, -1.73) m" in text
    assert "Eq. 15's time was not finite" in text and "Controls: upright in 1 of 1" in text
    assert "met in 1/2 = 0.50 [0.01, 0.99]" in text and "(not finite in 1 of 2)" in text
    assert "5 simulations" in text
    assert render_cliff([None]).startswith("*No data yet")

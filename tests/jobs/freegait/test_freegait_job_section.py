"""The one-job section of docs/freegait.md from its ledger (issue 28): `gaitmend reproduce
freegait-job` appends each job (the walk, its controls, its robustness re-runs) and skips
the jobs already there; the section renders the controls and robustness tables and the
comparisons from the stored summaries (small hand-made summaries here, no simulation)."""

from __future__ import annotations

import json

from app.jobs.freegait.reproduce import experiments as fx
from app.jobs.freegait.spec import FreegaitSpec


def _m(**kw) -> dict:
    m = {"finished": True, "footholds_in_zones": 0, "footholds_in_safe_areas": 0, "closest_zone_m": 0.084,
         "min_sm_m": 0.12, "min_k_r_m": 0.01, "stop_time_s": 0.0, "mean_speed_m_s": 0.019,
         "tracking_error_max_m": 0.046, "foothold_error_max_m": 0.009, "transfers": 17, "failed_touchdowns": 0,
         "time_s": 100.0}
    return m | kw


def _ctl(name: str, label: str, **kw) -> dict:
    return {"name": name, "label": label, "metrics": _m(**kw), "target_met": None, "evaluations": 1, "note": ""}


def summary(density: float, zones: int, unaware_in_zones: int) -> dict:
    cases = [{"name": "friction_0.7", "label": "friction x0.7", "metrics": _m(min_sm_m=0.116, tracking_error_max_m=0.035),
              "target_met": True},
             {"name": "dt_half", "label": "timestep halved", "metrics": _m(transfers=18, footholds_in_zones=1),
              "target_met": False}]
    return _m() | {
        "footholds": 51, "field": {"zones": zones, "density_per_m2": density, "zone_radius_m": 0.025, "safe_radius_m": 0.075,
                                   "x_range_m": [-1.0, 3.0], "y_range_m": [-2.0, 2.0], "roughness_m": 0.04},
        "route": {"distance_m": 2.0, "speed_m_s": 0.02},
        "controls": [_ctl("unaware", "zones ignored", footholds_in_zones=unaware_in_zones, footholds_in_safe_areas=5),
                     _ctl("periodic", "periodic tripod", transfers=34, min_sm_m=0.072, tracking_error_max_m=0.124),
                     _ctl("random_valid", "random valid tripod", transfers=20, min_k_r_m=-0.002, stop_time_s=0.4)],
        "robustness": {"target": "finishes, 0 in zones", "cases": cases, "spread": {}}}


def ledger(*densities: float, planned: int = 2) -> dict:
    runs = [{"name": f"job {d:g}", "key": str(d), "spec": {"d": d}, "seed": 0, "code_version": "v", "wall_s": 64.4,
             "cpu_s": 43.0, "result": summary(d, int(15 * d), 1 if d > 5 else 0)} for d in densities]
    return {"schema": 1, "experiment": "freegait-job", "command": "gaitmend reproduce freegait-job --write-docs",
            "params": {}, "code_version": "v", "planned": planned, "runs": runs, "superseded": []}


def test_the_section_renders_each_job_its_controls_and_robustness():
    md = fx.render_job([ledger(8.0, 3.0)])
    assert md.index("**3 zones/m^2** (45 zones over the 4 x 4 m terrain") < md.index("**8 zones/m^2** (120 zones")
    assert "the job's walks took 64 s wall, 43 s CPU" in md
    assert "| walk (zones known) | yes | 0 | 0 | 0.120 | 0.010 | 0.0 | 17 | 0.046 |" in md
    assert "| control: random valid tripod | yes | 0 | 0 | 0.120 | -0.002 | 0.4 | 20 | 0.046 |" in md
    assert "- periodic tripod: 34 transfers against the walk's 17, minimum SM 0.072 against 0.120 m" in md
    assert "- unaware control: footholds in zones 1, in safe areas 5 (the walk: 0, 0)" in md  # the 8/m^2 job
    assert "closest foot centre to a zone centre: 0.084 m" in md
    assert md.count("1 of 2 cases meet it") == 2
    assert "| timestep halved | yes | 1 | 0 | 0.120 |" in md
    assert "minimum SM 0.004 m, tracking error max 0.011 m; 1 of 2 cases keep" in md
    assert "Partial" not in md


def test_a_partial_or_missing_ledger_says_so():
    assert "1 of 2 planned runs" in fx.render_job([ledger(3.0)])
    assert fx.render_job([None]).startswith("*No data yet: `gaitmend reproduce freegait-job --write-docs` writes "
                                            "docs/freegait_job.json")


def test_the_experiment_runs_the_default_job_spec_appends_and_skips(tmp_path, monkeypatch):
    assert fx.job_spec(3.0) == FreegaitSpec.parse({"kind": "freegait"}).model_dump(mode="json")
    ran: list[dict] = []

    def fake(spec):
        ran.append(spec)
        return summary(spec["forbidden"]["density_per_m2"], 46, 0)

    monkeypatch.setattr(fx, "_job_run", fake)
    p = fx.JobParams(json_out=tmp_path / "job.json")
    logs: list[str] = []
    md = fx.job(p, logs.append)
    data = json.loads((tmp_path / "job.json").read_text())
    assert [r["name"] for r in data["runs"]] == ["job 3", "job 8"] and data["planned"] == 2
    assert [s["forbidden"]["density_per_m2"] for s in ran] == [3.0, 8.0]
    assert md == fx.render_job([data])
    fx.job(p, logs.append)  # both jobs are in the file: nothing runs again
    assert len(ran) == 2 and sum("skipped" in m for m in logs) == 2

"""The Table II reproduction writes each run as it finishes and resumes after a stop."""

import json

import pytest
from app.jobs.recovery.reproduce import experiments as reproduce


def test_table2_resumes_and_formats(tmp_path, monkeypatch):
    monkeypatch.setattr(reproduce, "SCENARIOS", [(3, 4)])
    raw = tmp_path / "t2.json"
    calls = []
    md = reproduce.run_table2(seeds=1, generations=1, population=4, raw_path=raw, log=calls.append)
    rows = json.loads(raw.read_text())
    assert len(rows) == 1 and rows[0]["lost_legs"] == [3, 4] and len(calls) == 1
    assert "| Legs 3 & 4 lost | modified_pentagonal | 1 |" in md
    assert "10.1 / 52.7 / 5.8" in md  # the paper's row beside ours
    row = rows[0]
    assert "from_log" not in row and row["version"] == reproduce.ROW_VERSION
    assert set(row["best_params"]) and row["random_search"]["metrics"] and row["robustness"]["total"] == 7
    assert "none transcribed" in md and "dt_half" in md  # the perturbation table
    # A second call finds the run on disk and does not simulate again.
    md2 = reproduce.run_table2(seeds=1, generations=1, population=4, raw_path=raw, log=calls.append)
    assert md2 == md and len(calls) == 1


def test_old_format_rows_are_dropped_not_tabled(tmp_path, monkeypatch):
    monkeypatch.setattr(reproduce, "SCENARIOS", [(3, 4)])
    raw = tmp_path / "t2.json"
    raw.write_text(json.dumps([{"lost_legs": [3, 4], "seed": 0, "generations": 1, "population": 4,
                                "best": {"x_f_m": 0.0, "y_f_m": 9.9, "yaw_f_deg": 0.0, "fell": False},
                                "from_log": True}]))
    calls = []
    reproduce.run_table2(seeds=1, generations=1, population=4, raw_path=raw, log=calls.append)
    rows = json.loads(raw.read_text())
    assert len(calls) == 1 and len(rows) == 1 and "from_log" not in rows[0]


def test_convergence_rule_on_the_documented_answers():
    """The rule (app/jobs/recovery/reproduce/convergence.py) on every answer the docs report at the default step
    (Table II, the robust comparison's nominal answers, the convergence searches),
    re-simulated here at the step and at half of it: the docs' verdict and numbers are what
    the code gives (docs/recovery.md, "Timestep"). At 1 ms the answers for the paper's four
    damages pass the rule; over every documented answer (34 when this was written; the count
    grows with Table II's seeds) two answers of short, rocking two-leg walks (legs 3 & 6,
    legs 5 & 6) move 5.8 % and 6.1 % forward, so the whole set fails its forward criterion,
    and this test says so."""
    from pathlib import Path

    import numpy as np

    from app.jobs.recovery.spec import RecoverySpec
    from app.jobs.recovery.reproduce.convergence import check, halving_deltas

    dt = RecoverySpec().sim.timestep_s
    answers = reproduce.documented_answers(dt, Path(__file__).resolve().parents[3] / "docs")
    assert len(answers) >= 8, "the docs must report enough recovered answers to check the rule on"
    rep = reproduce.convergence_report(answers, dt)
    doc = json.loads((Path(__file__).resolve().parents[3] / "docs/recovery_convergence.json").read_text())
    documented = next(r for r in doc if r["timestep_s"] == dt and r.get("set") == "documented")
    assert rep["passes"] == documented["passes"] and rep["forward_ok"] == documented["forward_ok"]
    assert rep["answers"] == documented["answers"] and rep["share_within"] == pytest.approx(documented["share_within"])
    for got, want in zip(rep["per_answer"], documented["per_answer"]):
        assert got["lost_legs"] == want["lost_legs"]
        for k in ("x_cm", "y_cm", "yaw_deg"):
            # bit-identical on one machine; another CPU (its SIMD paths in MuJoCo and numpy) moves a
            # 10 s contact-rich walk by ~1e-6 relative (1.3e-5 deg of yaw on an AVX-512 EPYC against
            # the machine that wrote the JSON): far below the one decimal the docs print
            assert got[k] == pytest.approx(want[k], rel=1e-5, abs=1e-4)
    # the paper's four damages (Table II) pass the rule at the default step
    paper = [a for a in rep["per_answer"] if tuple(a["lost_legs"]) in reproduce.SCENARIOS]
    assert len(paper) >= 8

    def at(j):  # the paper answers' metrics at the step (0) or at half of it (1)
        return {"x_f_m": np.array([a["x_cm"][j] for a in paper]) / 100,
                "y_f_m": np.array([a["y_cm"][j] for a in paper]) / 100,
                "yaw_f_deg": np.array([a["yaw_deg"][j] for a in paper])}

    assert check(halving_deltas(at(0), at(1)))["passes"]

"""PSO against random search at equal budget (paper 001), on a small fixed budget for CI;
the full comparison over five seeds is in docs/multigait.md."""

import json

import pytest

from app.jobs.multigait.reproduce.compare import CompareParams, compare, mann_whitney, ruggedness


def test_mann_whitney_is_one_sided():
    t = mann_whitney([5, 6, 7, 8, 9], [0, 1, 2, 3, 4])
    assert t["U"] == 25 and t["p"] == pytest.approx(1 / 252)
    assert mann_whitney([0, 1, 2, 3, 4], [5, 6, 7, 8, 9])["p"] == pytest.approx(1.0)


def test_pso_and_random_search_at_equal_budget(tmp_path):
    p = CompareParams(seeds="0,1,2", arms="constriction,random,paper", particles=6, generations=4, heldout=3,
                      gait_s=4.0, iterations=30, out=tmp_path / "c.md", json_out=tmp_path / "c.json",
                      robustness=True)
    md = compare(p, log=lambda s: None)
    rows = json.loads((tmp_path / "c.json").read_text())
    assert sorted((r["arm"], r["seed"]) for r in rows) == sorted(
        (a, s) for a in ("constriction", "random", "paper") for s in (0, 1, 2))
    for r in rows:
        assert r["evaluations"] == r["history"][-1]["evaluations"] == 24  # the same budget for every arm
        assert r["history"][-1]["best"] == r["in_sample_best"] > 0
        assert 0 < r["heldout_mean"] <= 100 and 0 <= r["dt_half_coverage"] <= 100
    # the paper's coefficients pin the swarm to the walls; constriction does not
    late = {a: [h["at_bounds"] for r in rows if r["arm"] == a for h in r["history"][1:]]
            for a in ("paper", "constriction")}
    assert min(late["paper"]) > 0.05 and max(late["constriction"]) < min(late["paper"])
    for r in rows:  # every best re-simulated under the job's six robustness cases
        assert set(r["robustness"]) == {"dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_-10pct",
                                        "mass_+10pct"}
        assert r["robustness"]["dt_half"] == r["dt_half_coverage"]  # the same re-simulation, done twice
    assert "| constriction: mean" in md or "| **constriction: mean**" in md
    assert "Mann-Whitney" in md and md.count("U = ") == 6  # 3 metrics x 2 PSO arms against random search
    assert (tmp_path / "c.md").read_text() == md
    # a second call keeps the runs it has (a long comparison resumes)
    again = compare(p.model_copy(update={"report_only": True}), log=lambda s: None)
    assert again == md


def test_ruggedness_measures_replans_and_perturbations():
    r = ruggedness(n=6, streams=2, iterations=20, eps=(0.001, 0.05), gait_s=3.0)
    assert r["n"] == 6 and -1 <= r["planner"]["corr"] <= 1 and r["planner"]["std_within_set"] >= 0
    assert [q["eps"] for q in r["perturbed"]] == [0.001, 0.05]
    assert all(-1 <= q["corr"] <= 1 and q["mean_abs_change"] >= 0 for q in r["perturbed"])

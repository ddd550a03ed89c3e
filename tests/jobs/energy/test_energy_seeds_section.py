"""The seed study's sections of docs/energy.md from its ledger (issue 28): the experiment runs
at the energy spec's default budget, and the renderers table only the runs at the budget of
the ledger's params, naming the earlier budget's runs the file keeps (hand-made rows here,
no optimisation)."""

from __future__ import annotations

from app.jobs.energy.reproduce import experiments as ex
from app.jobs.energy.spec import EnergySpec, Search


def result(T: float, ga_j: float, rs_j: float, cot: float, walks: bool = True) -> dict:
    return {"gait": {"period_s": T}, "links_m": [0.06, 0.33, 0.33], "J": ga_j, "cot": {"final": cot},
            "eps_ratio_nlp_over_qp": 100.0, "periodicity_error": 0.5,
            "physics": {"stays_up": walks, "cot": cot + 0.1, "speed_m_s": 1.0},
            "controls": [{"name": "random_search", "metrics": {"J": rs_j, "cot_final": 0.6}},
                         {"name": "paper_table1", "metrics": {"cot_final": 1.0}}]}


def run(seed: int, pop: int, gen: int, r: dict, wall: float = 400.0) -> dict:
    spec = ex.seeds_spec(ex.SeedsParams(population=pop, generations=gen), seed)
    return {"key": f"k{seed}-{pop}", "name": f"seed {seed}", "spec": spec, "seed": seed, "code_version": "v",
            "wall_s": wall, "cpu_s": 10.0, "result": r}


def ledger(runs: list[dict], pop: int = 40, gen: int = 40, planned: int = 5) -> dict:
    params = ex.SeedsParams(population=pop, generations=gen).model_dump(mode="json")
    return {"schema": 1, "experiment": "energy-seeds", "command": ex.SEEDS_COMMAND, "params": params,
            "code_version": "v", "planned": planned, "runs": runs, "superseded": []}


SMALL = [run(s, 12, 8, result(0.9, 0.70, 0.60, 0.55, walks=False), wall=100.0) for s in range(5)]


def test_the_default_budget_is_the_energy_specs():
    p = ex.SeedsParams()
    assert (p.population, p.generations) == (Search().population, Search().generations)
    assert p.period_bounds == "0.3,1.5" and p.seeds == "0,1,2,3,4"
    spec = EnergySpec.parse(ex.seeds_spec(p, 3))
    assert spec.search.seed == 3 and spec.gait.period_bounds_s == [0.3, 1.5]
    assert spec.evidence.random_search and spec.evidence.controls and not spec.evidence.robustness
    assert spec.search.population * (spec.search.generations + 1) == 1640


def test_only_the_params_budget_is_tabled_and_the_earlier_runs_are_named():
    big = [run(0, 40, 40, result(1.2, 0.60, 0.65, 0.50), wall=412.0),
           run(1, 40, 40, result(1.49, 0.61, 0.64, 0.52, walks=False), wall=655.0)]
    md = ex.render_seeds([ledger(SMALL + big)])
    assert md.startswith("GA 40 x (40 + 1) = 1640 evaluations per seed (the energy spec's default)")
    assert "seeds 0, 1;" in md and "took 412-655 s wall" in md
    assert "The file also keeps 5 earlier runs at 12 x (8 + 1) (not tabled here)." in md
    assert "| 0 | 1.200 |" in md and "| 1 | 1.490 (bound) |" in md and "0.900" not in md
    assert "in 1/2 = 0.50" in md  # on the bound: seed 1 only (1.49 >= 1.5 x 0.99)
    assert "Partial: 2 of 5 planned runs" in md
    controls = ex.render_controls([ledger(SMALL + big)])
    assert "range over the 2 seeds" in controls and "CoT final 0.500-0.520" in controls
    summary = ex.render_seeds_summary([ledger(SMALL + big)])
    assert "2 seeds" in summary and "0.50-0.52x Table 1's CoT" in summary and "bound in 1 of 2 seeds" in summary


def test_the_paired_verdict_over_five_default_seeds():
    big = [run(s, 40, 40, result(1.0 + s / 100, 0.60 + s / 1000, 0.70 + s / 100, 0.5)) for s in range(5)]
    md = ex.render_seeds([ledger(SMALL + big)])
    assert "Partial" not in md and "in 0/5 = 0.00" in md
    assert "GA against its random search, J (lower is better): +0.1" in md  # every pair favours the GA
    assert "**not shown (interval excludes 0, but 5 pairs cannot give Wilcoxon p < 0.05)**" in md
    summary = ex.render_seeds_summary([ledger(big)])
    # the verdict is on J, named as such, and the cost of transport's own verdict stands beside it
    assert "GA vs random search at equal budget, on J (the search's objective" in summary
    assert "): not shown (interval excludes 0" in summary
    assert "on the final cost of transport random search is lower in 0 of 5 seeds" in summary


def test_a_small_budget_ledger_still_renders_as_its_own_budget():
    md = ex.render_seeds([ledger(SMALL, pop=12, gen=8)])
    assert md.startswith("GA 12 x (8 + 1) = 108 evaluations per seed (the default is 40 x (40 + 1) = 1640)")
    assert "earlier runs" not in md


def test_no_run_at_the_params_budget_is_no_data():
    assert "No data yet" in ex.render_seeds([ledger(SMALL)])
    assert "No data yet" in ex.render_controls([ledger(SMALL)])
    assert ex.render_seeds_summary([ledger(SMALL)]) == ""

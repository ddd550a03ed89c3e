"""app/jobs/multigait/reproduce/experiments.py's generated words: the generation-mean sentence says
what the paired verdict shows (a rise, a fall, or neither), and the seeds-needed column of
the PSO-against-random table is never below the pairs the signed-rank test can reject with."""

from __future__ import annotations

import re

import pytest

from app.jobs import stats
from app.jobs.multigait.reproduce import experiments as ex
from app.jobs.multigait.reproduce.compare import METRICS


def _run(first: float, last: float, best: float = 20.0) -> dict:
    """One paper-budget run whose swarm mean is ``first`` over the first WINDOW
    generations and ``last`` over the last WINDOW."""
    hist = [{"mean": first} for _ in range(ex.WINDOW)] + [{"mean": last} for _ in range(ex.WINDOW)]
    return {"history": hist, "result": {"final_best": best}}


def _claim(pairs: list[tuple[float, float]]) -> str:
    return ex.render_mean_claim([[_run(a, b) for a, b in pairs]])


def test_a_shown_rise_says_the_mean_does_rise():
    text = _claim([(4.0, 4.0 + 0.5 + 0.1 * i) for i in range(7)])
    assert "(shown)**" in text and "**does rise**, by about 0.8 points" in text
    assert "the best's 5x" in text  # 20 % against the first generations' 4.0 %


def test_a_rise_that_is_not_shown_is_not_called_one():
    # four runs, every one up: the t interval excludes 0, but 4 pairs cannot give p < 0.05
    four = _claim([(4.0, 5.0), (4.0, 5.2), (4.0, 4.9), (4.0, 5.1)])
    assert stats.fewest_pairs() > 4
    assert "not shown (interval excludes 0" in four
    assert "does rise" not in four and "**not shown** either way" in four
    mixed = _claim([(4.0, 4.0 + d) for d in (0.3, -0.4, 0.2, -0.1, 0.5, -0.3, 0.1, -0.2)])
    assert "does rise" not in mixed and "**not shown** either way" in mixed


def test_a_shown_fall_says_it_falls():
    text = _claim([(5.0, 4.0 - 0.1 * i) for i in range(7)])
    assert "**falls**, by about 1.3 points" in text and "does rise" not in text and "toward worse" in text


def _compare_rows(diff: float, n: int) -> list[dict]:
    rows = []
    for seed in range(n):
        for arm, add in (("random", 0.0), ("paper", diff), ("constriction", diff)):
            rows.append({"arm": arm, "seed": seed, "particles": 20, "generations": 20, "evaluations": 400,
                         **{key: 10.0 + add + 0.3 * ((seed * 7) % 5) * (arm != "random") for key, _ in METRICS}})
    return rows


@pytest.mark.parametrize("n", [3, 5])
def test_seeds_needed_is_never_below_what_the_signed_rank_test_can_reject_with(n):
    text = ex.render_compare_stats([_compare_rows(10.0, n)])
    floor = stats.fewest_pairs()
    assert f"at least {floor}: the signed-rank test cannot reject with fewer" in text
    needed = [int(line.rsplit("|", 2)[1]) for line in text.splitlines() if re.match(r"\| (paper|constriction) vs", line)]
    assert len(needed) == 2 * len(METRICS)
    assert needed == [floor] * len(needed)  # a 10-point difference with a spread under 1: the t-test alone needs 2-3
    # fewer seeds than the floor: no advantage is excluded, however large
    assert f"at this budget and {n} seeds no true advantage of PSO is excluded, however large" in text
    six = ex.render_compare_stats([_compare_rows(0.1, floor)])
    assert "however large" not in six and "smaller than the power column is not excluded" in six


def test_the_full_budget_cost_is_scaled_from_the_runs_own_wall_time():
    rows = _compare_rows(1.0, 5)
    assert "full budget" not in ex.render_compare_stats([rows])  # no wall times: no estimate
    for i, r in enumerate(rows):
        r["wall_s"] = 400 * (1.0 + 0.5 * (i % 3))  # 1, 1.5, 2 s an evaluation: median 1.5
    text = ex.render_compare_stats([rows])
    # 1.5 s x 3000 evaluations = 75 min a run; 2 arms x 6 seeds (the fewest that can show a difference)
    assert f"2 arms x {stats.fewest_pairs()} seeds" in text and stats.fewest_pairs() == 6
    assert "one arm's run would take about 75 min here and 2 arms x 6 seeds about 15 h" in text
    assert "these 15 runs' wall time (median 1.50 s an evaluation" in text
    # once runs at the full budget exist, their measured cost replaces the estimate
    measured = ex.render_compare_stats([rows, _full_rows(2)])
    assert "would take about" not in measured and "4 arm-runs took 30-31 min each (wall)" in measured
    assert "predicted about 75 min" in measured


def _full_rows(seeds: int, paper_only: tuple[int, ...] = ()) -> list[dict]:
    rows = []
    for seed in range(seeds):
        for arm in ("random", "paper"):
            v = 20.0 + seed + (1.5 + 0.2 * seed) * (arm == "paper")
            rows.append({"arm": arm, "robot": "lizard", "seed": seed, "particles": 20, "generations": 150,
                         "evaluations": 3000, "in_sample_best": v, "heldout_mean": v - 1, "heldout_std": 0.5,
                         "dt_half_coverage": v - 2, "history": [{"mean": 5.0}, {"mean": 6.0}],
                         "wall_s": 1800.0 + 60 * seed, "code_version": "682f10d40b77"})
    for seed in paper_only:  # an arm whose partner has not run yet: no pair
        rows.append(dict(rows[-1], seed=seed))
    return rows


def test_the_full_budget_comparison_states_what_it_has_and_what_is_left():
    assert "No data yet" in ex.render_compare_full([[]])
    floor = stats.fewest_pairs()
    one = ex.render_compare_full([_full_rows(1, paper_only=(1,))])
    # one seed with both arms (seed 1 has only the swarm): no interval, no verdict, the rest to run
    assert "Paired by seed" not in one and "**" not in one.split("Mann-Whitney")[0] and "verdict" not in one
    assert f"1 of the {floor} seeds the signed-rank test needs" in one
    assert f"the {floor - 1} seeds left need about {2 * (floor - 1) * 1800 / 3600:.1f} h" in one
    assert "code 682f10d40b77" in one and "| paper | 1 |" in one  # every run is listed
    two = ex.render_compare_full([_full_rows(2)])
    assert "Paired by seed" in two and two.count(": **not shown") == len(METRICS)  # 2 pairs cannot show anything
    assert "no difference can be shown either way" in two
    done = ex.render_compare_full([_full_rows(floor)])
    assert "seeds left" not in done and "no difference can be shown" not in done
    assert done.count("**paper better (shown)**") == len(METRICS) and ": **not shown" not in done  # every seed favours the swarm

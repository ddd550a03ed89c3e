"""The bundle's convergence figure says what the job page's convergence plot says (issue 25):
the same series, under the same names, in the same colours and lines, with the same axis
titles. The page's side is what the dashboard serves (kind.history_axis, the /views
"convergence") read as web/static/job.js reads it (tests/results/convergence_page.py); the
figure's is read back from the matplotlib figure the kind's ``figures`` saves."""

from __future__ import annotations

import pytest

from app.jobs.base import JobResult
from app.jobs.registry import get_kind
from tests.results.convergence_page import figure_plot, page_plot, saved_figures  # noqa: F401 (fixture)


def _result(summary: dict, history: list[dict]) -> JobResult:
    return JobResult(summary=summary, history=history, traces={}, model_xml="", evaluations=0, sim_steps=0)


def _recovery_history(worst: bool = True) -> list[dict]:
    """As the DE writes it: best so far, the generation's mean, worst and best, and counts
    the page does not plot (fell, cut, target_met, evaluations)."""
    return [{"generation": g, "best": 10.0 + g, "mean": 4.0 + g, "worst": (1.0 + g) if worst else None,
             "generation_best": 9.0 + g, "fell": 2, "cut": 1, "target_met": 0, "evaluations": 12 * (g + 1)}
            for g in range(4)]


ENERGY_SUMMARY = {"task": {"speed_m_s": 0.5},
                  "gait": {"period_s": 0.46, "legs": ["FR", "HR", "FL", "HL"], "touchdown_s": [0.0, 0.23, 0.23, 0.0],
                           "duty": [0.5, 0.5, 0.5, 0.5]}}


def _energy_history() -> list[dict]:
    """As the GA writes it with its random-search control merged in (energy/run._merge_history)."""
    return [{"generation": g, "evaluations": 4 * (g + 1), "best": 2.0 / (g + 1), "generation_best": 2.5 / (g + 1),
             "mean": 1e4, "worst": 1e4, "feasible_share": 0.5, "mean_feasible": 3.0, "best_cot": 0.4,
             "random_search_best": 3.0 / (g + 1), "random_search_generation_best": 3.5 / (g + 1),
             "random_search_feasible_share": 0.25} for g in range(3)]


CASES = {
    "recovery": ({}, {}, _recovery_history()),
    "recovery, no worst in the history": ({}, {}, _recovery_history(worst=False)),
    "energy": ({}, ENERGY_SUMMARY, _energy_history()),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_convergence_figure_draws_what_the_page_draws(case, tmp_path, saved_figures):
    kind = get_kind(case.split(",")[0])
    spec, summary, history = CASES[case]
    kind.figures(_result(summary, history), tmp_path)
    page = page_plot(kind.history_axis(spec), history)
    assert page["traces"], "the page draws nothing: the case tests nothing"
    assert figure_plot(saved_figures["convergence.png"]) == page


def test_the_page_and_the_figure_agree_on_an_empty_history(tmp_path, saved_figures):
    """An energy job without a search (search.optimizer = none): no lines either side, the
    same axis titles."""
    kind = get_kind("energy")
    kind.figures(_result(ENERGY_SUMMARY, []), tmp_path)
    fig = figure_plot(saved_figures["convergence.png"])
    assert fig == page_plot(kind.history_axis({}), []) and fig["traces"] == []


def test_the_energy_figure_names_every_series_it_draws_not_only_the_best(tmp_path, saved_figures):
    """The figure's y label was "best J (Eq. 11)" over the GA's generation bests and the
    random search: the label is the quantity, the legend says which J each line is."""
    kind = get_kind("energy")
    kind.figures(_result(ENERGY_SUMMARY, _energy_history()), tmp_path)
    fig = figure_plot(saved_figures["convergence.png"])
    assert fig["y"] == "J (Eq. 11), lower better"
    assert [t[0] for t in fig["traces"]] == ["GA: best so far", "GA: best of the generation",
                                             "random search (same budget): best so far"]

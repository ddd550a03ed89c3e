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


CASES = {
    "recovery": ({}, {}, _recovery_history()),
    "recovery, no worst in the history": ({}, {}, _recovery_history(worst=False)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_convergence_figure_draws_what_the_page_draws(case, tmp_path, saved_figures):
    kind = get_kind(case.split(",")[0])
    spec, summary, history = CASES[case]
    kind.figures(_result(summary, history), tmp_path)
    page = page_plot(kind.history_axis(spec), history)
    assert page["traces"], "the page draws nothing: the case tests nothing"
    assert figure_plot(saved_figures["convergence.png"]) == page

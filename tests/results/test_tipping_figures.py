"""The tipping bundle's figures say what the job page's plots say (issue 25): the margin
timeline, the foot forces and the tilt draw the same lines under the same names, in the
same colours and dashes, clipped and cut the same, with the same axis titles, events and
notes as the page's panels (app/jobs/tipping/views.py), read back through
tests/results/panel_page.py."""

from __future__ import annotations

import numpy as np
import pytest

from app.jobs.base import JobResult
from app.jobs.registry import get_kind
from app.jobs.tipping import views as tip
from tests.jobs.tipping.cases import tipping_summary
from tests.results.convergence_page import saved_figures  # noqa: F401 (fixture)
from tests.results.panel_page import figure_panel, page_panel


def tipping_case() -> tuple[dict, dict]:
    """Without recovery the robot tips over at 12 s (FASM -180 deg after, body at 120 deg);
    with recovery the judgment fires at 5 s and leg 6 lands at 6.2 s; the QP drives legs 1,
    3 and 5 from 5 s; the platform tilt is longer in the run that did not fall."""
    t = np.round(np.arange(0, 20, 0.02), 2)
    fall = t >= 12.0
    n = len(t)
    qp = np.zeros((n, 6))
    qp[t >= 5.0, 0], qp[t >= 5.0, 2], qp[t >= 5.0, 4] = 9e3, 8e3, 7e3
    base = {"time_s": t[:650], "fasm_deg": np.where(fall, -180.0, 30 - 2 * t)[:650], "ssm_m": (0.5 - 0.01 * t)[:650],
            "nesm_m": (0.2 + 0 * t)[:650], "foot_fz_n": np.tile(np.arange(1, 7) * 1e3, (650, 1)),
            "tilt_rel_deg": np.where(fall, 120.0, 0.0)[:650], "platform_tilt_deg": (2 * t)[:650],
            "edge_leg_a": np.where(t < 8, 3, 1)[:650], "edge_leg_b": np.where(t < 8, 5, 3)[:650], "qp_fz_n": np.zeros((650, 6))}
    reco = {"time_s": t, "fasm_deg": np.where(t > 6, 35.0, 30 - 2 * t), "ssm_m": 0.5 - 0.01 * t, "nesm_m": 0.2 + 0 * t,
            "foot_fz_n": np.tile(np.arange(1, 7) * 1e3, (n, 1)), "tilt_rel_deg": 0 * t, "platform_tilt_deg": 2 * t,
            "edge_leg_a": np.full(n, 3), "edge_leg_b": np.full(n, 5), "qp_fz_n": qp}
    return tipping_summary(), {"no_recovery": base, "recovery": reco}


FIGURES = {"margin_timeline": "margin", "foot_forces": "forces", "tilt": "tilt"}  # file -> page panel


@pytest.fixture
def drawn(tmp_path, saved_figures):  # noqa: F811 (the fixture)
    summary, traces = tipping_case()
    result = JobResult(summary=summary, history=[], traces=traces, model_xml="", evaluations=0, sim_steps=0)
    get_kind("tipping").figures(result, tmp_path)
    panels = {p["id"]: p for p in tip.views(summary, traces)}
    return panels, saved_figures


@pytest.mark.parametrize("name", list(FIGURES))
def test_the_figure_draws_what_the_page_draws(name, drawn):
    panels, figs = drawn
    page = page_panel(panels[FIGURES[name]])
    assert page["series"], "the page draws nothing: the case tests nothing"
    assert figure_panel(figs[f"{name}.png"], page["title"]) == page


def test_both_cut_the_margin_where_the_robot_tipped_and_mark_it(drawn):
    """The colleague's list (issue 25): the PNG clipped to [-60, 90] deg, ran on past the
    fall and had no 'tipped over' marker."""
    panels, figs = drawn
    ax = figs["margin_timeline.png"].axes[0]
    without = next(ln for ln in ax.get_lines() if ln.get_label() == "FASM without recovery")
    assert max(without.get_xdata()) <= 12.0 and min(without.get_ydata()) >= tip.CLIP[0] == -45.0
    cross = next(ln for ln in ax.get_lines() if ln.get_label() == "tipped over (without recovery)")
    assert list(cross.get_xdata()) == [12.0] and ax.get_ylim()[0] == pytest.approx(-50.0)


def test_the_tilt_is_clipped_and_the_platform_comes_from_the_longest_run(drawn):
    _, figs = drawn
    lines = {ln.get_label(): ln for ln in figs["tilt.png"].axes[0].get_lines()}
    assert max(lines["body vs ground, without recovery"].get_ydata()) == 90.0
    assert max(lines["platform tilt"].get_xdata()) == pytest.approx(19.98)  # the run with recovery, not the first

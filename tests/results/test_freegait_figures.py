"""The freegait bundle's figures say what the job page's plots say (issue 25): the
minefield and the margins draw the same series under the same names, in the same colours
and markers, with the same axis titles, SM_min and body stops as the page's panels
(app/jobs/freegait/views.py), read back through tests/results/panel_page.py. The page's
one map with the control behind its legend entries is two panels in the figure (a static
image cannot hide a series until clicked): the same series, legend names and colours."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.colors import ROLES
from app.jobs.base import JobResult
from app.jobs.freegait import views as fg
from app.jobs.registry import get_kind
from tests.results.convergence_page import saved_figures  # noqa: F401 (fixture)
from tests.results.panel_page import figure_panel, page_panel


def freegait_case() -> tuple[dict, dict]:
    """A walk with no foothold in a zone and two body stops, its control (zones ignored)
    with one foothold in a zone."""
    t = np.round(np.arange(0, 6, 0.1), 1)
    n = len(t)
    stop = ((t >= 1.0) & (t < 1.5)) | ((t >= 4.0) & (t < 4.3))
    phase = np.zeros((n, 6), dtype=int)
    phase[np.ix_((t % 1.0) < 0.5, [0, 3, 4])] = 1  # tripod 1 in transfer each first half second
    walk = {"time_s": t, "pos": np.c_[0.05 * t, 0.01 * t, 0.3 + 0 * t], "sm_m": 0.08 + 0.02 * np.sin(t),
            "k_r_m": 0.05 * np.cos(t), "stop": stop.astype(int), "phase": phase}
    control = {"time_s": t, "pos": np.c_[0.05 * t, -0.01 * t, 0.3 + 0 * t]}
    feet = [{"x": 0.1 * i, "y": 0.2 * (i % 2), "in_zone": False, "leg": 1 + i % 6, "t": 0.5 * i} for i in range(6)]
    ctl = [dict(f, y=f["y"] - 0.05, in_zone=i == 2) for i, f in enumerate(feet)]
    summary = {"field": {"zones": 2, "density_per_m2": 1.0, "zone_radius_m": 0.025, "safe_radius_m": 0.075,
                         "roughness_m": 0.0},
               "zones": [[0.2, 0.15], [0.35, -0.1]], "footholds_list": feet, "sm_min_m": 0.05, "target_met": True,
               "control_footholds": {"name": "unaware", "footholds": ctl}}
    return summary, {"walk": walk, "unaware": control}


FIGURES = {"minefield": "minefield", "margins": "margins"}  # file -> page panel


@pytest.fixture
def drawn(tmp_path, saved_figures):  # noqa: F811 (the fixture)
    summary, traces = freegait_case()
    result = JobResult(summary=summary, history=[], traces=traces, model_xml="", evaluations=0, sim_steps=0)
    get_kind("freegait").figures(result, tmp_path)
    return {p["id"]: p for p in fg.views(summary, traces)}, saved_figures


@pytest.mark.parametrize("name", list(FIGURES))
def test_the_figure_draws_what_the_page_draws(name, drawn):
    panels, figs = drawn
    page = page_panel(panels[FIGURES[name]])
    assert page["series"], "the page draws nothing: the case tests nothing"
    fig = figure_panel(figs[f"{name}.png"], page["title"])
    if name == "minefield":  # the figure titles each run's panel with its count; the page says it in the caption
        fig["notes"] = page["notes"]
    assert fig == page


def test_the_margins_legend_names_every_series_and_the_stops(drawn):
    """The colleague's list (issue 25): the PNG's legend had only SM_min (red, the page's
    grey) and its lines matplotlib's default colours."""
    panels, figs = drawn
    fig = figure_panel(figs["margins.png"])
    assert fig["legend"] == sorted(["SM", "K_R", "SM_min", "body stopped"])
    assert ("SM_min", ROLES["threshold"], ("line", "dash", 2.0)) in fig["series"]["SM (m)"]
    assert fig["spans"] == [(1.0, 1.5, ROLES["failure"]), (4.0, 4.3, ROLES["failure"])]


def test_the_minefield_names_and_colours_each_run_as_the_page(drawn):
    _, figs = drawn
    fig = figure_panel(figs["minefield.png"])
    assert "walk: footholds" in fig["legend"] and "control (unaware): in a forbidden zone" in fig["legend"]
    zones = {p.get_facecolor()[:3] for ax in figs["minefield.png"].axes for p in ax.patches}
    from matplotlib.colors import to_rgb
    assert zones == {to_rgb(ROLES["forbidden"]), to_rgb(ROLES["safe_area"])}

"""On a real short walk (the smoke job, its control and no robustness): the bundle's
minefield and margins figures draw what the job page's panels draw (issue 25; the
comparison of tests/results/panel_page.py, the synthetic cases in
tests/results/test_freegait_figures.py)."""

from __future__ import annotations

from app.jobs.base import MemoryContext
from app.jobs.freegait import KIND
from tests.results.convergence_page import saved_figures  # noqa: F401 (fixture)
from tests.results.panel_page import figure_panel, page_panel


def test_a_real_walk_figures_match_the_page(tmp_path, saved_figures):  # noqa: F811 (the fixture)
    spec = KIND.smoke_spec() | {"evidence": {"controls": True, "robustness": False}}
    res = KIND.run(KIND.Spec.parse(spec), MemoryContext())
    assert res.summary.get("control_footholds"), "no control on the map: the case tests half of it"
    KIND.figures(res, tmp_path)
    panels = {p["id"]: p for p in KIND.views(res.summary, res.traces)}
    for name in ("minefield", "margins"):
        page = page_panel(panels[name])
        fig = figure_panel(saved_figures[f"{name}.png"], page["title"])
        if name == "minefield":  # the figure titles each run's panel with its count; the page says it in the caption
            fig["notes"] = page["notes"]
        assert fig == page, name
    assert page["series"]["SM (m)"] and page["legend"].count("SM_min") == 1

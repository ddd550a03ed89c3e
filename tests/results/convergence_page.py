"""What the job page's convergence plot draws (web/static/job.js, convergence()), written
out once for the tests that hold a bundle's convergence figure against it: the series of
the kind's ``history_axis`` (the dashboard's /views "convergence", kind.history_axis) that
hold a number in some history row, in that order, named by their labels, coloured and
dashed from the colour table (common.js: page_table's history roles and history_lines, or
the palette from its third colour), the y title with the direction appended."""

from __future__ import annotations

from pathlib import Path

import pytest
from matplotlib.colors import to_hex
from matplotlib.figure import Figure

from app.core.colors import page_table

MPL_DASH = {"solid": "-", "dot": ":", "dash": "--"}


def page_plot(axis: dict, rows: list[dict]) -> dict:
    """The page's plot of ``rows`` under ``axis``: x and y titles, and per drawn trace its
    name, colour, dash and width, as job.js builds them (no Python of the app's involved)."""
    table = page_table()
    names = axis["series"]
    keys = [k for k in names if any(type(r.get(k)) in (int, float) for r in rows)]  # typeof r[k] === "number"
    traces = []
    for i, k in enumerate(keys):
        role = table["history"].get(k)
        colour = table["roles"][role] if role else table["palette"][(i + 2) % len(table["palette"])]
        dash, width = table["history_lines"].get(k, ["solid", 2])
        traces.append((names[k], colour, dash, width))
    better = f", {axis['better']} better" if axis.get("better") else ""
    return {"x": axis["x"], "y": f"{axis['y']}{better}", "traces": traces}


def figure_plot(fig: Figure) -> dict:
    """The same description read back from a bundle's convergence figure: its axis labels,
    its lines (label, colour, dash, width at the figure's 0.75 px per page px) and its legend."""
    ax = fig.axes[0]
    dash = {v: k for k, v in MPL_DASH.items()}
    lines = [(ln.get_label(), to_hex(ln.get_color()), dash[ln.get_linestyle()], ln.get_linewidth() / 0.75)
             for ln in ax.get_lines()]
    legend = ax.get_legend()
    texts = [t.get_text() for t in legend.get_texts()] if legend is not None else []
    assert texts == [ln[0] for ln in lines], (texts, lines)  # every line in the legend, nothing else
    return {"x": ax.get_xlabel(), "y": ax.get_ylabel(), "traces": lines}


@pytest.fixture
def saved_figures(monkeypatch) -> dict[str, Figure]:
    """file name -> the matplotlib Figure saved under it (kept after the plots close it)."""
    figs: dict[str, Figure] = {}
    real = Figure.savefig

    def spy(self, fname, *args, **kw):
        figs[Path(fname).name] = self
        return real(self, fname, *args, **kw)

    monkeypatch.setattr(Figure, "savefig", spy)
    return figs

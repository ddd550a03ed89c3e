"""What a job page's plot panel draws and what a bundle figure draws, written out as the
same description so a test can hold one against the other (issue 25): per y axis (by its
title) the lines and marker series (name, colour, dash or marker, width in page px), the
legend's entries, the vertical event lines with their texts, the shaded spans, the axis
and plot titles. The page's side reads the panel JSON the dashboard serves, which
web/static/views.js hands to plotly unchanged; the figure's reads the matplotlib figure
back (lines at the figures' 0.75 px per page px)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from matplotlib.colors import to_hex
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

MPL_DASH = {"-": "solid", ":": "dot", "--": "dash", "-.": "dashdot"}
PAGE_MARKER = {"circle": "o", "circle-open": "o", "x": "x", "square": "s"}  # plotly symbol -> matplotlib's
PX = 0.75


def _title(ax_layout: dict | None) -> str:
    return ((ax_layout or {}).get("title") or {}).get("text", "")


def _round(v) -> float:
    return round(float(v), 3)


def page_panel(panel: dict) -> dict:
    """The description of a page panel (kit.panel with a plotly figure)."""
    fig = panel["figure"]
    layout, series, legend = fig["layout"], defaultdict(list), []
    for tr in fig["data"]:
        y = _title(layout.get("yaxis" + tr.get("yaxis", "y")[1:]))
        if tr.get("mode", "lines") == "markers":
            m = tr.get("marker", {})
            hollow = m.get("symbol", "circle").endswith("-open")
            style = ("marker", PAGE_MARKER[m.get("symbol", "circle")], hollow)
            colour = m["color"]
        else:
            style = ("line", tr["line"].get("dash", "solid"), _round(tr["line"].get("width", 2)))
            colour = tr["line"]["color"]
        series[y].append((tr["name"], colour.lower(), style))
        if tr.get("showlegend", True) is not False:
            legend.append(tr["name"])
    vlines, spans, hlines = [], [], []
    for s in layout.get("shapes", []):
        if s["type"] == "line" and s.get("xref") == "x" and s["x0"] == s["x1"]:
            vlines.append((_round(s["x0"]), s["line"]["color"].lower(), s["line"].get("dash", "solid")))
        elif s["type"] == "line" and s["y0"] == s["y1"]:
            hlines.append((_title(layout.get("yaxis" + s.get("yref", "y")[1:])), _round(s["y0"]), s["line"]["color"].lower()))
        elif s["type"] == "rect" and s.get("yref") == "paper":
            spans.append((_round(s["x0"]), _round(s["x1"]), s["fillcolor"].lower()))
            if s.get("showlegend"):
                legend.append(s["name"])
    notes = sorted(a["text"].replace("<b>", "").replace("</b>", "") for a in layout.get("annotations", []))
    xs = sorted({_title(v) for k, v in layout.items() if k.startswith("xaxis")} - {""})
    return {"title": panel["title"], "series": {k: sorted(v) for k, v in series.items()}, "legend": sorted(legend),
            "vlines": sorted(vlines), "hlines": sorted(hlines), "spans": sorted(spans), "notes": notes, "x": xs}


def _line_style(ln) -> tuple:
    if ln.get_linestyle() in ("None", "", " "):
        hollow = ln.get_markerfacecolor() == "none"
        return ("marker", ln.get_marker(), hollow)
    return ("line", MPL_DASH[ln.get_linestyle()], _round(ln.get_linewidth() / PX))


def figure_panel(fig: Figure, title: str | None = None) -> dict:
    """The same description read back from a saved figure: every axes' lines by its y
    label (a line whose label starts with "_" is drawn but kept out of the legend, as a page
    trace with showlegend false), axvline / axhline as event and reference lines, axvspan as
    shaded spans, texts as notes, legend entries over all axes."""
    series, legend, vlines, hlines, spans, notes, xs = defaultdict(list), [], [], [], [], [], set()
    for ax in fig.axes:
        y = ax.get_ylabel()
        for ln in ax.get_lines():
            xd, yd = np.asarray(ln.get_xdata(), dtype=float), np.asarray(ln.get_ydata(), dtype=float)
            blended = ln.get_transform() != ax.transData
            if blended and len(xd) == 2 and xd[0] == xd[1]:
                vlines.append((_round(xd[0]), to_hex(ln.get_color()), MPL_DASH[ln.get_linestyle()]))
            elif blended and len(yd) == 2 and yd[0] == yd[1]:
                hlines.append((y, _round(yd[0]), to_hex(ln.get_color())))
            else:
                series[y].append((ln.get_label().lstrip("_"), to_hex(ln.get_color()), _line_style(ln)))
        for p in ax.patches:
            if isinstance(p, (Rectangle, Polygon)) and p.get_label() != "" and p.get_transform() != ax.transData:
                xy = np.asarray(p.get_xy()) if isinstance(p, Polygon) else np.array([[p.get_x(), 0], [p.get_x() + p.get_width(), 0]])
                spans.append((_round(xy[:, 0].min()), _round(xy[:, 0].max()), to_hex(p.get_facecolor())))
        leg = ax.get_legend()
        legend += [t.get_text() for t in leg.get_texts()] if leg is not None else []
        notes += [t.get_text() for t in ax.texts]
        notes += [ax.get_title(loc) for loc in ("left",) if ax.get_title(loc)]
        xs.add(ax.get_xlabel())
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()] + ([fig._suptitle.get_text()] if fig._suptitle else [])
    return {"title": title if title in titles else titles, "series": {k: sorted(v) for k, v in series.items()},
            "legend": sorted(legend), "vlines": sorted(vlines), "hlines": sorted(hlines),
            "spans": sorted(set(spans)),  # one page span (yref paper) shades every row of the figure
            "notes": sorted(notes), "x": sorted(xs - {""})}

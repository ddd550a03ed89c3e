"""Building blocks for a kind's dashboard views (``Kind.views``): plotly figure dicts and
tables as plain JSON, so the page draws whatever a kind supplies without knowing the kind;
and the shared evidence tables (controls, robustness) every kind's summary carries.

A view is a panel: {"id", "title", "caption", and either "figure": {"data", "layout"} or
"table": {"columns": [...], "rows": [[cell, ...]]}}. A cell is a number, a string, None,
or {"value", "unit"?, "met"?: bool, "better"?: bool} when it carries a judgement (met a
target / better than the control), which the page marks in colour AND in words.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from app.core.colors import PALETTE, ROLES
from app.jobs.records import CaseResult, ControlRow, Robustness, controls_of, robustness_of

# Roles from the one colour table: the method's answer and its control keep one colour
# everywhere (plots, tables, replay), so "recovered" never swaps colour with "baseline".
METHOD = ROLES["method"]
CONTROL = ROLES["baseline"]
NEUTRAL = ROLES["mean"]
TARGET = ROLES["threshold"]
GRID = "#e3e8ee"
MAX_POINTS = 1200


def finite(x: Any) -> Any:
    """JSON has no NaN or infinity: those become None (a gap in a line)."""
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def series(a: Any, step: int = 1, scale: float = 1.0, digits: int = 5) -> list:
    """A 1-D array as a JSON list, every ``step``-th value, rounded, NaN as None."""
    v = np.asarray(a, dtype=float)[::step] * scale
    out = np.round(v, digits).tolist()
    return [x if math.isfinite(x) else None for x in out]


def stride(n: int, limit: int = MAX_POINTS) -> int:
    return max(1, -(-n // limit))


def line(x, y, name: str, color: str, **kw) -> dict:
    t = {"type": "scatter", "mode": "lines", "x": x, "y": y, "name": name, "line": {"color": color, "width": 2}}
    for k, v in kw.items():
        if k == "dash":
            t["line"]["dash"] = v
        elif k == "width":
            t["line"]["width"] = v
        else:
            t[k] = v
    return t


def hline(y: float, text: str, color: str = TARGET, yref: str = "y", dash: str = "dash") -> tuple[dict, dict]:
    """A horizontal reference line across the plot (shape) and its label (annotation)."""
    shape = {"type": "line", "xref": "paper", "x0": 0, "x1": 1, "yref": yref, "y0": y, "y1": y,
             "line": {"color": color, "width": 2, "dash": dash}}
    note = {"xref": "paper", "x": 1, "xanchor": "right", "yref": yref, "y": y, "yanchor": "bottom", "text": text,
            "showarrow": False, "font": {"color": color, "size": 12}}
    return shape, note


def vline(x: float, text: str, color: str, dash: str = "dot", yref: str = "paper", row_top: float = 1.0) -> tuple[dict, dict]:
    shape = {"type": "line", "xref": "x", "x0": x, "x1": x, "yref": "paper", "y0": 0, "y1": row_top,
             "line": {"color": color, "width": 1.5, "dash": dash}}
    note = {"xref": "x", "x": x, "yref": "paper", "y": row_top, "yanchor": "bottom", "text": text, "showarrow": False,
            "font": {"color": color, "size": 11}, "textangle": 0}
    return shape, note


def axis(title: str, **kw) -> dict:
    return {"title": {"text": title}, "gridcolor": GRID, "zerolinecolor": "#b9c2cf", **kw}


def figure(data: list[dict], layout: dict) -> dict:
    return {"data": data, "layout": layout}


def panel(pid: str, title: str, caption: str = "", figure: dict | None = None, table: dict | None = None,
          height: int | None = None) -> dict:
    p: dict[str, Any] = {"id": pid, "title": title, "caption": caption}
    if figure is not None:
        if height:
            figure["layout"]["height"] = height
        p["figure"] = figure
    if table is not None:
        p["table"] = table
    return p


def cell(value: Any, unit: str | None = None, met: bool | None = None, better: bool | None = None,
         text: str | None = None, note: str | None = None) -> dict:
    c: dict[str, Any] = {"value": finite(value)}
    if note:
        c["note"] = note
    if unit:
        c["unit"] = unit
    if met is not None:
        c["met"] = bool(met)
    if better is not None:
        c["better"] = bool(better)
    if text is not None:
        c["text"] = text
    return c


def table(columns: list[str], rows: list[list[Any]]) -> dict:
    return {"columns": columns, "rows": [[finite(c) if not isinstance(c, dict) else c for c in r] for r in rows]}


def stacked(n: int, gap: float = 0.06) -> list[list[float]]:
    """y-axis domains of n panels stacked top to bottom."""
    h = (1 - gap * (n - 1)) / n
    return [[1 - (i + 1) * h - i * gap, 1 - i * (h + gap)] for i in range(n)]


def swing_intervals(t: np.ndarray, contact: np.ndarray) -> list[tuple[float, float]]:
    """Swing phases (foot off the ground) of one leg as (start, end) times."""
    c = np.asarray(contact).astype(bool)
    t = np.asarray(t, dtype=float)
    if not len(t):
        return []
    off = ~c
    edges = np.diff(off.astype(int))
    starts = list(np.where(edges == 1)[0] + 1)
    ends = list(np.where(edges == -1)[0] + 1)
    if off[0]:
        starts.insert(0, 0)
    if off[-1]:
        ends.append(len(t) - 1)
    return [(float(t[s]), float(t[e])) for s, e in zip(starts, ends)]


# -- the shared evidence: controls and robustness, as every kind's summary carries them --------

def _metric_cols(items: list[ControlRow] | list[CaseResult]) -> list[str]:
    cols: list[str] = []
    for it in items:
        cols += [k for k in it.metrics if k not in cols]
    return cols


# a metric key's unit suffix -> (unit, scale): "y_f_m" is worded "y f (m)", "share_frac" "share (%)"
SUFFIXES = (("_deg_s", "°/s", 1.0), ("_m_s", "m/s", 1.0), ("_deg", "°", 1.0), ("_rad", "rad", 1.0), ("_pct", "%", 1.0),
            ("_frac", "%", 100.0), ("_mu", "mu", 1.0), ("_kg", "kg", 1.0), ("_N", "N", 1.0), ("_s", "s", 1.0),
            ("_m", "m", 1.0))


def metric_name(key: str, names: dict[str, tuple[str, str, float]] | None = None) -> tuple[str, str, float]:
    """(label, unit, scale) of a record's metric key: the kind's ``metric_names``, else the
    key worded from its unit suffix."""
    if names and key in names:
        return names[key]
    for suf, unit, scale in SUFFIXES:
        if key.endswith(suf) and len(key) > len(suf):
            return key[: -len(suf)].replace("_", " "), unit, scale
    return key.replace("_", " "), "", 1.0


def _nice(key: str, names: dict | None = None) -> str:
    label, unit, _ = metric_name(key, names)
    return f"{label} ({unit})" if unit else label


def _met_cell(v: Any) -> Any:
    if v is None:
        return cell("no target", text="–")
    return cell("met" if v else "not met", met=bool(v))


def _metric_cell(v: Any, key: str = "", names: dict | None = None) -> Any:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)) and not isinstance(v, bool) and key:
        scale = metric_name(key, names)[2]
        return finite(round(v * scale, 6)) if scale != 1.0 else finite(v)
    if isinstance(v, (list, dict)):
        return ", ".join(str(x) for x in v) if isinstance(v, list) else str(v)
    return finite(v)


def controls_panel(summary: dict, names: dict | None = None) -> dict | None:
    """The controls table, its metrics worded and scaled by ``names`` (the kind's
    ``metric_names``)."""
    items = controls_of(summary) if isinstance(summary.get("controls"), list) else []
    if not items:
        return None
    cols = [c for c in _metric_cols(items) if not isinstance(items[0].metrics.get(c), (list, dict))]
    rows = [[cell(it.label or _nice(it.name), note=it.note or None), it.evaluations]
            + [_metric_cell(it.metrics.get(c), c, names) for c in cols] + [_met_cell(it.target_met)] for it in items]
    cap = ("Controls at the same evaluation budget as the method unless the note says otherwise: the baseline, a random "
           "search over the same space, and the method with each part switched off. They measure how much of the result "
           "the method earns; the verdict at the top of the page compares the method with each.")
    return panel("controls", "Controls", cap,
                 table=table(["control (and how it was run)", "evaluations"] + [_nice(c, names) for c in cols] + ["target"],
                             rows))


def _robustness_caption(rob: Robustness) -> str:
    parts = [f"{rob.met} of {rob.total} cases meet the target"]
    groups = [(g, *rob.count(g)) for g in ("physical", "numerics")]
    if all(n for _, _, n in groups):
        parts.append(", ".join(f"{met} of {n} {g}" for g, met, n in groups))
    return (f"The final answer re-simulated under changed conditions (finer timestep, perturbed friction and masses, ...). "
            f"Target checked: {rob.target or '–'}. " + "; ".join(parts) + ".")


def robustness_panel(summary: dict, names: dict | None = None) -> dict | None:
    rob = robustness_of(summary)
    if rob is None or not rob.cases:
        return None
    cols = [c for c in _metric_cols(rob.cases) if not isinstance(rob.cases[0].metrics.get(c), (list, dict))]
    rows = [[c.label or _nice(c.name)] + [_metric_cell(c.metrics.get(k), k, names) for k in cols]
            + [_met_cell(c.target_met)] for c in rob.cases]
    p = panel("robustness", "Robustness", _robustness_caption(rob),
              table=table(["case"] + [_nice(c, names) for c in cols] + ["target"], rows))
    if rob.spread:
        p["table"]["foot"] = [[_nice(k, names)] + [_metric_cell(v.get(x), k, names) for x in ("nominal", "min", "max")]
                              for k, v in rob.spread.items() if isinstance(v, dict)]
        p["table"]["foot_columns"] = ["metric", "nominal", "min", "max"]
    p["summary"] = {"met": rob.met, "total": rob.total}
    return p

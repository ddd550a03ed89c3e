"""A study's plots for its page (GET /api/studies/{id}/views): one chart per reported
metric (median with the [min, max] range of each group), then whatever the base's kind
draws from the points (``Kind.study_views``: the tipping polar success rate, the recovery
damage atlas). Panels have the shape of a job's views (app/jobs/viewkit.py), so the page
renders both with the same code. Computed from the stored job rows on every request."""

from __future__ import annotations

import json
from typing import Any

from app.jobs import viewkit as kit
from app.jobs.base import SpecError
from app.jobs.registry import get_kind

MAX_METRIC_PANELS = 8


def group_label(group_by: list[str], values: list[Any]) -> str:
    if not group_by:
        return "all points"
    return ", ".join(f"{g.split('.')[-1]} {json.dumps(v)}" for g, v in zip(group_by, values))


def metric_panel(i: int, metric: str, agg: dict[str, Any]) -> dict | None:
    labels, med, lo, hi, ns = [], [], [], [], []
    for r in agg["rows"]:
        st = r["metrics"][metric]
        if not st["n"]:
            continue
        labels.append(group_label(agg["group_by"], r["group"]))
        med.append(kit.finite(st["median"]))
        lo.append(kit.finite(st["median"] - st["min"]))
        hi.append(kit.finite(st["max"] - st["median"]))
        ns.append(st["n"])
    if not labels:
        return None
    data = [{"type": "scatter", "mode": "markers", "x": labels, "y": med, "name": "median",
             "marker": {"color": kit.METHOD, "size": 10},
             "error_y": {"type": "data", "symmetric": False, "array": hi, "arrayminus": lo, "color": kit.METHOD},
             "customdata": ns, "hovertemplate": "%{x}: median %{y:.4g} (n = %{customdata})<extra></extra>"}]
    layout = {"xaxis": kit.axis(", ".join(g.split(".")[-1] for g in agg["group_by"]) or "group", type="category"),
              "yaxis": kit.axis(metric), "hovermode": "closest", "showlegend": False}
    cap = (f"{metric}: median over each group's succeeded points (the non-grouped axes, e.g. seeds), the bar from the "
           f"smallest to the largest value.")
    return kit.panel(f"metric-{i}", metric, cap, kit.figure(data, layout), height=340)


def study_views(spec: dict[str, Any], points: list[dict[str, Any]], agg: dict[str, Any]) -> list[dict]:
    """spec: the study spec; points: store.point_rows (overrides, spec, status, summary)."""
    panels = [p for i, m in enumerate(agg["metrics"][:MAX_METRIC_PANELS]) if (p := metric_panel(i, m, agg))]
    try:
        kind = get_kind(spec["base"]["kind"])
    except SpecError:
        return panels
    return kind.study_views(spec, points) + panels

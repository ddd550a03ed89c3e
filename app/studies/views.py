"""A study's page parts (GET /api/studies/{id}/views): the verdict pooled over each group's
points (seeds), the aggregate as a table with readable names and units, whatever the base's
kind draws from the points (``Kind.study_views``: the tipping polar success rate, the
recovery damage atlas), then one chart per reported metric (median with the [min, max]
range of each group). Panels have the shape of a job's views (app/jobs/viewkit.py), so the
page renders both with the same code. Computed from the stored job rows on every request."""

from __future__ import annotations

import json
from typing import Any

from app.jobs import viewkit as kit
from app.jobs.base import SpecError
from app.jobs.registry import get_kind
from app.studies.spec import HEADLINE, get_path, slug

MAX_METRIC_PANELS = 8
HIDDEN_SEGMENTS = ("metrics", "result", "summary")


def value_text(v: Any) -> str:
    """A group's value as a person reads it: lists joined, no JSON 'null' (the spec's default)."""
    if v is None:
        return "default"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, list):
        return ", ".join(value_text(x) for x in v) or "none"
    return str(v) if isinstance(v, (str, int, float)) else json.dumps(v)


def group_label(group_by: list[str], values: list[Any]) -> str:
    if not group_by:
        return "all points"
    return ", ".join(f"{g.split('.')[-1].replace('_', ' ')} {value_text(v)}" for g, v in zip(group_by, values))


def metric_name(kind, path: str, summary: dict | None) -> tuple[str, str, float]:
    """(label, unit, scale) of a reported metric path: a headline row's own label and unit;
    else the last key through the kind's ``metric_names`` (or worded from its unit suffix),
    after the path's other segments ('best.metrics.y_f_m' -> 'best forward', 'cm', 100)."""
    parts = path.split(".")
    if parts[0] == HEADLINE and len(parts) == 2 and kind is not None and summary is not None:
        try:
            rows = kind.headline(summary)
            row = kind.list_headline(summary) if parts[1] == "primary" else \
                next((r for r in rows if slug(r["label"]) == parts[1]), None)
        except (KeyError, TypeError, ValueError):
            row = None
        if row is not None:
            return row["label"], row.get("unit") or "", 1.0
    names = kind.metric_names(summary) if kind is not None and summary is not None else {}
    label, unit, scale = kit.metric_name(parts[-1], names)
    context = [p.replace("_", " ") for p in parts[:-1] if p not in HIDDEN_SEGMENTS and p != HEADLINE]
    return " ".join([*context, label]), unit, scale


def _titled(label: str, unit: str) -> str:
    return f"{label} ({unit})" if unit else label


def metric_panel(i: int, metric: str, agg: dict[str, Any], name: tuple[str, str, float]) -> dict | None:
    label, unit, scale = name
    labels, med, lo, hi, ns = [], [], [], [], []
    for r in agg["rows"]:
        st = r["metrics"][metric]
        if not st["n"]:
            continue
        labels.append(group_label(agg["group_by"], r["group"]))
        med.append(kit.finite(st["median"] * scale))
        lo.append(kit.finite((st["median"] - st["min"]) * scale))
        hi.append(kit.finite((st["max"] - st["median"]) * scale))
        ns.append(st["n"])
    if not labels:
        return None
    title = _titled(label, unit)
    data = [{"type": "scatter", "mode": "markers", "x": labels, "y": med, "name": "median",
             "marker": {"color": kit.METHOD, "size": 10},
             "error_y": {"type": "data", "symmetric": False, "array": hi, "arrayminus": lo, "color": kit.METHOD},
             "customdata": ns, "hovertemplate": "%{x}: median %{y:.4g} (n = %{customdata})<extra></extra>"}]
    layout = {"xaxis": kit.axis(", ".join(g.split(".")[-1].replace("_", " ") for g in agg["group_by"]) or "group",
                                type="category"),
              "yaxis": kit.axis(title), "hovermode": "closest", "showlegend": False}
    cap = (f"{title} (reported as {metric}): median over each group's succeeded points (the non-grouped axes, e.g. "
           "seeds), the bar from the smallest to the largest value.")
    return kit.panel(f"metric-{i}", title, cap, kit.figure(data, layout), height=340)


def aggregate_panel(agg: dict[str, Any], names: dict[str, tuple[str, str, float]]) -> dict:
    """The aggregate table: a row per group, each metric as median [min, max] in its unit."""
    cols = [g.split(".")[-1].replace("_", " ") for g in agg["group_by"]] + ["done / points"]
    cols += [f"{_titled(*names[m][:2])}: median [min, max]" for m in agg["metrics"]]
    rows = []
    for r in agg["rows"]:
        cells: list[Any] = [value_text(v) for v in r["group"]] or []
        cells.append(f"{r['succeeded']} / {r['points']}")
        for m in agg["metrics"]:
            st, sc = r["metrics"][m], names[m][2]
            cells.append("–" if not st["n"] else
                         f"{st['median'] * sc:.4g} [{st['min'] * sc:.4g}, {st['max'] * sc:.4g}]")
        rows.append(cells)
    if not agg["group_by"]:
        cols.insert(0, "group")
        for row in rows:
            row.insert(0, "all points")
    cap = "Each group's succeeded points (the other axes, e.g. seeds): the median and, in brackets, the range."
    return kit.panel("aggregate", "Aggregate", cap, table=kit.table(cols, rows))


def _point_verdicts(kind, points: list[dict], group_by: list[str]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for p in points:
        if p["status"] != "succeeded" or not p.get("summary"):
            continue
        values = [p["overrides"].get(g, get_path(p["spec"], g)) for g in group_by]
        try:
            v = kind.verdict(p["summary"])
            if (v.get("target") or {}).get("met") is None:
                v = {**v, "unjudged": unjudged_target(kind.headline(p["summary"]))}
            out.setdefault(json.dumps(values), []).append(v)
        except (KeyError, TypeError, ValueError):  # a summary of an older release
            continue
    return out


def unjudged_target(headline: list[dict]) -> dict | None:
    """A target the kind states but did not judge this point by (recovery: a walk under
    3 s, unless it fell): the headline row that carries it, its value saying why in words
    (the job page's rule, web/static/job.js). None: the kind has no target of its own."""
    return next((dict(r) for r in headline if r.get("target") and r.get("met") is None
                 and isinstance(r.get("value"), str)), None)


def target_cell(verdicts: list[dict], met: list[int]) -> Any:
    """The group's target column: k of n points met it; the points not judged by it say
    why (the target for their walk in the note); "no target" only where the kind has none."""
    rows = [v["unjudged"] for v in verdicts if v.get("unjudged")]
    if not rows:
        return f"{met[0]} of {met[1]}" if met[1] else "no target"
    words = sorted({str(r["value"]) for r in rows})
    why = "; ".join(words)
    text = (f"{met[0]} of {met[1]}; {len(rows)} {why}" if met[1] else
            why if len(rows) == len(verdicts) else f"{len(rows)} of {len(verdicts)} {why}")
    return kit.cell(text, text=text, note="; ".join(sorted({str(r["target"]) for r in rows})))


def held_out_cell(h: dict | None) -> Any:
    """The group's held-out random models kept over its points, the value their share (the
    column sorts by it), the words app/jobs/verdict.py's and a fragile group marked."""
    if not h:
        return kit.cell(None, text="–")
    kept = f"{h['met']} of {h['judged']}" if h["judged"] else f"{h['n']} not judged"
    return kit.cell(h["share"], better=False if h["fragile"] else None,
                    text=kept + ("" if h["fell"] is None else f", {h['fell']} fell"),
                    note=f"{h['text']} over {h['points']} point(s)" + ("; fragile" if h["fragile"] else ""))


def verdict_panel(kind, points: list[dict], group_by: list[str]) -> dict | None:
    """The method against each control pooled over each group's points (seeds): the mean
    paired difference with its 95 % interval and Wilcoxon p (app/jobs/verdict.py's
    ``pooled``), beat / lost only when the interval excludes 0 and p < 0.05, else "not
    shown" with the reason in the cell's note; target met and robustness counted over the
    points."""
    from app.jobs.verdict import FRAGILE_RULE, fmt, study_verdict

    groups = _point_verdicts(kind, points, group_by)
    rows = []
    for key, verdicts in groups.items():
        v = study_verdict(verdicts)
        label = group_label(group_by, json.loads(key))
        met = v["target_met"]
        rob = v["robustness"]
        base = [label, target_cell(verdicts, met), held_out_cell(v["held_out"]),
                f"{rob[0]} of {rob[1]}" if rob else "–"]
        if not v["controls"]:
            rows.append(base + ["–", "–", "–"])
        for c in v["controls"]:
            mean, ci = c["mean"], c["interval"]
            diff = "–" if mean is None else f"{fmt(mean, c['unit'])} ({c['on']}, {c['better']} is better)"
            inter = "one seed: no interval" if ci is None else f"{fmt(ci[0], c['unit'])} to {fmt(ci[1], c['unit'])}"
            p = "" if c["p"] is None or ci is None else f"; Wilcoxon p = {c['p']:.3g}"
            word = c["outcome"]
            rows.append(base + [c["label"], kit.cell(word, better=True if c["outcome"] == "beat" else
                                                     False if c["outcome"] == "lost" else None, text=word,
                                                     note=f"{c['n']} seed(s): {c['why']}"), f"{diff}; 95 % interval {inter}{p}"])
    if not rows:
        return None
    cap = ("Did the method work over the seeds? Per group: the points meeting the target, the held-out random "
           f"models keeping it over the points (their falls; {FRAGILE_RULE}; sort by it), the named-case and "
           "timestep re-runs meeting it, and the method against each control at the same budget as the mean paired difference over "
           "the points (positive: the method is better) with its 95 % interval (Student t below 10 seeds, BCa "
           "bootstrap from 10) and Wilcoxon's signed-rank p; beat or lost only when the interval excludes 0 and "
           "p < 0.05, else 'not shown' (the reason in the cell's note), never a finding either way.")
    return kit.panel("verdict", "Verdict over the seeds", cap,
                     table=kit.table(["group", "target met", "held-out models kept", "re-runs met", "control",
                                      "outcome", "method minus control"], rows))


def study_views(spec: dict[str, Any], points: list[dict[str, Any]], agg: dict[str, Any]) -> list[dict]:
    """spec: the study spec; points: store.point_rows (overrides, spec, status, summary)."""
    try:
        kind = get_kind(spec["base"]["kind"])
    except SpecError:
        kind = None
    sample = next((p["summary"] for p in points if p["status"] == "succeeded" and p.get("summary")), None)
    names = {m: metric_name(kind, m, sample) for m in agg["metrics"]}
    panels = [p for i, m in enumerate(agg["metrics"][:MAX_METRIC_PANELS]) if (p := metric_panel(i, m, agg, names[m]))]
    head = [aggregate_panel(agg, names)]
    if kind is None:
        return head + panels
    verdict = verdict_panel(kind, points, agg["group_by"])
    return ([verdict] if verdict else []) + head + kind.study_views(spec, points) + panels

"""The study's aggregate table: points grouped by ``report.group_by``, each metric as
median [min, max] over the points of the group (the non-grouped axes, e.g. seeds).
Computed from the job summaries every time it is asked for, never stored, so it is
right after retries, restarts and worker crashes."""

from __future__ import annotations

import csv
import io
import json
import math
import statistics
from typing import Any

from app.studies.spec import get_path


def _value_key(v: Any) -> str:
    return json.dumps(v, sort_keys=True)


def _number(v: Any) -> float | None:
    if isinstance(v, bool):
        return float(v)
    if isinstance(v, (int, float)) and math.isfinite(v):
        return float(v)
    return None


def aggregate(points: list[dict[str, Any]], group_by: list[str], metrics: list[str]) -> dict[str, Any]:
    """points: [{"index", "overrides", "spec", "status", "summary", "error"}] in point order."""
    groups: dict[str, dict[str, Any]] = {}
    for p in points:
        values = [p["overrides"].get(g, get_path(p["spec"], g)) for g in group_by]
        g = groups.setdefault(_value_key(values), {"group": values, "points": 0, "succeeded": 0, "failed": 0,
                                                   "values": {m: [] for m in metrics}})
        g["points"] += 1
        if p["status"] == "succeeded" and p.get("summary") is not None:
            g["succeeded"] += 1
            for m in metrics:
                if (x := _number(get_path(p["summary"], m))) is not None:
                    g["values"][m].append(x)
        elif p["status"] in ("failed", "cancelled"):
            g["failed"] += 1
    rows = []
    for g in groups.values():
        stats = {}
        for m, xs in g["values"].items():
            stats[m] = ({"median": statistics.median(xs), "min": min(xs), "max": max(xs), "n": len(xs)}
                        if xs else {"median": None, "min": None, "max": None, "n": 0})
        rows.append({"group": g["group"], "points": g["points"], "succeeded": g["succeeded"],
                     "failed": g["failed"], "metrics": stats})
    failed = [{"index": p["index"], "overrides": p["overrides"], "status": p["status"], "error": p.get("error")}
              for p in points if p["status"] in ("failed", "cancelled")]
    return {"group_by": group_by, "metrics": metrics, "rows": rows, "failed": failed}


def _fmt(x: float | None) -> str:
    return "" if x is None else f"{x:.4g}"


def cell(st: dict[str, Any]) -> str:
    if st["n"] == 0:
        return "-"
    return f"{_fmt(st['median'])} [{_fmt(st['min'])}, {_fmt(st['max'])}]"


def to_csv(agg: dict[str, Any]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    head = list(agg["group_by"]) + ["points", "succeeded", "failed"]
    for m in agg["metrics"]:
        head += [f"{m} median", f"{m} min", f"{m} max", f"{m} n"]
    w.writerow(head)
    for r in agg["rows"]:
        row = [json.dumps(v) if not isinstance(v, (str, int, float)) else v for v in r["group"]]
        row += [r["points"], r["succeeded"], r["failed"]]
        for m in agg["metrics"]:
            st = r["metrics"][m]
            row += [repr(st["median"]) if st["median"] is not None else "", repr(st["min"]) if st["min"] is not None else "",
                    repr(st["max"]) if st["max"] is not None else "", st["n"]]
        w.writerow(row)
    return buf.getvalue()


def to_markdown(agg: dict[str, Any], title: str = "", infeasible: list[dict] | None = None) -> str:
    head = list(agg["group_by"]) + ["done/points"] + [f"{m} (median [min, max])" for m in agg["metrics"]]
    lines = [f"# {title}", ""] if title else []
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in agg["rows"]:
        cells = [json.dumps(v) for v in r["group"]] + [f"{r['succeeded']}/{r['points']}"]
        cells += [cell(r["metrics"][m]) for m in agg["metrics"]]
        lines.append("| " + " | ".join(cells) + " |")
    if agg["failed"]:
        lines += ["", "Failed or cancelled points:", ""]
        lines += [f"- point {f['index']} {json.dumps(f['overrides'])}: {f['status']}: {f['error'] or ''}"
                  for f in agg["failed"]]
    if infeasible:
        lines += ["", "Infeasible points (listed, never run):", ""]
        lines += [f"- {json.dumps(x['overrides'])}: {x['reason']}" for x in infeasible]
    return "\n".join(lines) + "\n"

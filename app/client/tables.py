"""The API's answers as pandas DataFrames: job lists with their headline numbers, a
history, a study's points with their overrides and metrics."""

from __future__ import annotations

import io
import json
import zipfile
from typing import Any

JOB_COLUMNS = ["id", "kind", "robot", "damage", "status", "done", "total", "created_at", "finished_at", "wall_s",
               "error"]


def frame(rows: list[dict]):
    import pandas as pd

    return pd.DataFrame(rows)


def headline_columns(headline: list[dict] | None) -> dict[str, Any]:
    """{"label [unit]": value} of a job's headline rows."""
    out = {}
    for r in headline or []:
        name = f"{r['label']} [{r['unit']}]" if r.get("unit") else r["label"]
        out[name] = r["value"]
    return out


VERDICT_COLUMNS = ["held_out_kept", "held_out_n", "held_out_share", "held_out_fell", "fragile", "verdict"]


def verdict_columns(v: dict | None) -> dict[str, Any]:
    """The verdict's columns of a job: the held-out random models kept of n (and the share),
    the falls, fragile (app/jobs/verdict.py's thresholds) and the sentence; None where the
    job has no verdict or no held-out set."""
    h = (v or {}).get("held_out") or {}
    return {"held_out_kept": h.get("met"), "held_out_n": h.get("judged", h.get("n")), "held_out_share": h.get("share"),
            "held_out_fell": h.get("fell"), "fragile": h.get("fragile"), "verdict": (v or {}).get("sentence")}


def jobs_frame(items: list[dict]):
    """One row per job, newest first; the verdict (held-out kept, falls, fragile, its
    sentence) and the headline numbers of succeeded jobs as columns."""
    import pandas as pd

    rows = []
    for j in items:
        p = j.get("progress") or {}
        row = {k: j.get(k) for k in JOB_COLUMNS if k in j} | {"done": p.get("done"), "total": p.get("total")}
        rows.append(row | verdict_columns(j.get("verdict")) | headline_columns(j.get("headline")))
    df = pd.DataFrame(rows, columns=list(dict.fromkeys(JOB_COLUMNS + VERDICT_COLUMNS + [c for r in rows for c in r])))
    for col in ("created_at", "finished_at"):
        df[col] = pd.to_datetime(df[col], utc=True, format="ISO8601")
    return df


def studies_frame(items: list[dict]):
    import pandas as pd

    rows = [{"id": s["id"], "name": s["name"], "status": s["status"], "created_at": s["created_at"]}
            | {f"points_{k}" if k != "points" else "points": v for k, v in (s.get("progress") or {}).items()}
            for s in items]
    return pd.DataFrame(rows)


def dotted(data: Any, path: str) -> Any:
    """``data`` at a dotted path ("best.metrics.y_f_m"; a list index is a number), or None."""
    for part in path.split("."):
        if isinstance(data, dict):
            data = data.get(part)
        elif isinstance(data, list) and part.isdigit() and int(part) < len(data):
            data = data[int(part)]
        else:
            return None
    return data


def _cell(v: Any) -> Any:
    """A grid value as a DataFrame cell: lists (e.g. lost legs [1, 6]) become tuples, so a
    column can be grouped by and plotted against."""
    if isinstance(v, list):
        return tuple(_cell(x) for x in v)
    if isinstance(v, dict):
        return json.dumps(v, sort_keys=True)
    return v


def study_frame(bundle: bytes):
    """One row per point of a study bundle (GET /api/studies/{id}/bundle): its overrides,
    the report's metrics, the verdict's columns (held-out kept, falls, fragile, sentence)."""
    import pandas as pd

    with zipfile.ZipFile(io.BytesIO(bundle)) as z:
        manifest = json.loads(z.read("manifest.json"))
        points = [json.loads(z.read(n)) for n in sorted(z.namelist()) if n.startswith("points/")]
    metrics = manifest["study"]["report"]["metrics"]
    paths = list(dict.fromkeys(k for p in points for k in p["overrides"]))
    rows = []
    for p in points:
        row = {"index": p["index"], "job_id": p.get("job_id"), "status": p["status"]}
        row |= {path: _cell(p["overrides"].get(path)) for path in paths}
        row |= {m: dotted(p.get("summary"), m) for m in metrics}
        rows.append(row | verdict_columns(p.get("verdict")) | {"error": p.get("error")})
    return pd.DataFrame(rows, columns=["index", "job_id", "status", *paths, *metrics, *VERDICT_COLUMNS, "error"])

"""The study bundle: the aggregate as CSV and Markdown, every point's summary, and a
manifest whose ``study`` is the spec that reproduces the whole study
(`gaitmend study run manifest.json` or `gaitmend study submit manifest.json`)."""

from __future__ import annotations

import io
import json
import zipfile
from typing import Any

from app.jobs.base import dumps
from app.studies.aggregate import to_csv, to_markdown


def study_files(study_spec: dict, points: list[dict[str, Any]], agg: dict, infeasible: list[dict],
                extra: dict | None = None) -> dict[str, bytes]:
    from app import __version__

    files: dict[str, bytes] = {
        "aggregate.csv": to_csv(agg).encode(),
        "aggregate.md": to_markdown(agg, study_spec.get("name", ""), infeasible).encode(),
        "aggregate.json": dumps(agg).encode(),
    }
    for p in points:
        files[f"points/{p['index']:04d}.json"] = dumps({
            "index": p["index"], "overrides": p["overrides"], "status": p["status"], "error": p.get("error"),
            "job_id": p.get("job_id"), "spec": p["spec"], "summary": p.get("summary"),
            "verdict": point_verdict(study_spec, p)}).encode()
    manifest = {"format": "gaitmend-study/1", "gaitmend_version": __version__, "study": study_spec,
                "points": [{"index": p["index"], "overrides": p["overrides"], "job_id": p.get("job_id"),
                            "status": p["status"]} for p in points],
                "infeasible": infeasible} | (extra or {})
    files["manifest.json"] = json.dumps(manifest, indent=1).encode()
    return files


def point_verdict(study_spec: dict, p: dict[str, Any]) -> dict | None:
    """A succeeded point's verdict in brief (app/jobs/verdict.py's ``brief``: the held-out
    figure, target, controls, the sentence), as the job page and the API state it."""
    if p["status"] != "succeeded" or not p.get("summary"):
        return None
    from app.jobs.base import SpecError
    from app.jobs.registry import get_kind
    from app.jobs.verdict import brief

    try:
        return brief(get_kind(study_spec["base"]["kind"]).verdict(json.loads(dumps(p["summary"]))))
    except (SpecError, KeyError, TypeError, ValueError):  # a summary of an older release
        return None


def zip_bytes(files: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in sorted(files.items()):
            z.writestr(name, data)
    return buf.getvalue()


def load_study_file(data: Any) -> Any:
    """A study spec, or a study bundle's manifest (its ``study``)."""
    if isinstance(data, dict) and data.get("format") == "gaitmend-study/1" and "study" in data:
        return data["study"]
    return data

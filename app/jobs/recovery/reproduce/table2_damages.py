"""Paper 000's Table II damages (legs 1 & 6, 3 & 4, 1, 4 lost), which every recovery
reproduction runs, with the two things those reproductions share: a damage's name on the
pages and the rows file written whole (a long reproduction resumes from it)."""

from __future__ import annotations

import json
from pathlib import Path


SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]


def _save_rows(rows: list[dict], raw_path: Path | None) -> None:
    """Every finished run at once (a long reproduction resumes from it), never half-written."""
    if raw_path is None:
        return
    raw_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = raw_path.with_suffix(".part")
    tmp.write_text(json.dumps(rows, indent=1))
    tmp.replace(raw_path)


def _name(lost) -> str:
    return ("Legs " if len(lost) > 1 else "Leg ") + " & ".join(str(l) for l in lost) + " lost"

"""Paper 000's Table II damages (legs 1 & 6, 3 & 4, 1, 4 lost), which every recovery
reproduction runs, with the two things those reproductions share: a damage's name on the
pages, the rows file written whole (a long reproduction resumes from it), and the
seed-major order a ledgered comparison runs its jobs in."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any


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


def run_seed_major(ledger: Any, scenarios, seeds: int, parts, spec_of: Callable, run_of: Callable,
                   log: Callable[[str], None]) -> None:
    """Each (seed, damage, part) job through ``ledger.run`` (app/jobs/ledger.py: appended when
    it ends, skipped when already there), seed by seed so that a cut-short run still has every
    damage: ``spec_of(lost, seed, part)`` is the ledger's key spec, ``run_of(...)`` the job."""
    for seed in range(seeds):
        for lost in scenarios:
            for part in parts:
                name = f"legs {'-'.join(map(str, lost))} seed {seed} {part}"
                log(f"{name}: searching")
                ledger.run(name, spec_of(lost, seed, part), seed, lambda: run_of(lost, seed, part), log)

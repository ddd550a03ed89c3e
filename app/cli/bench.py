"""`gaitmend bench`: every registered kind's benchmark entries, measured in one go
(performance targets live in the kinds' entries, never in timed unit tests)."""

from __future__ import annotations

import os
from collections.abc import Callable

from app.jobs.registry import KINDS


def run_bench(quick: bool = False, log: Callable[[str], None] = print, kinds: list[str] | None = None) -> dict:
    figures: dict = {"cores": os.cpu_count(), "quick": quick}
    for name, kind in KINDS.items():
        if kinds is not None and name not in kinds:
            continue
        for entry in kind.bench():
            log(f"{entry.name}: {entry.help} ...")
            figures[entry.name] = entry.run(quick, log)
    return figures

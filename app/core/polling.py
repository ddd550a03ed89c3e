"""Waiting on a served resource (a job or a study behind the API) until it is no longer
queued or running, saying each new progress line once: the one loop the reproductions
that drive a served API share (app/cli/study_scaling.py, the repertoire's islands)."""

from __future__ import annotations

import time
from collections.abc import Callable

PENDING = ("queued", "running")


def wait_done(fetch: Callable[[], dict], line: Callable[[dict], str], log: Callable[[str], None],
              interval_s: float, t0: float) -> tuple[dict, float]:
    """Call ``fetch`` every ``interval_s`` until its ``status`` is no longer pending;
    ``log`` gets ``line(state)`` with the seconds since ``t0`` whenever the line changes.
    Returns (the final state, the seconds from ``t0`` to it)."""
    last = None
    while (state := fetch())["status"] in PENDING:
        text = line(state)
        if text != last:
            log(f"{text} ({time.monotonic() - t0:.0f} s)")
            last = text
        time.sleep(interval_s)
    return state, time.monotonic() - t0

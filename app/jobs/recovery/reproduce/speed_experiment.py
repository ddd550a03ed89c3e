"""The `gaitmend reproduce recovery-speed` experiment: its options and the run that measures
the parts (app/jobs/recovery/reproduce/speed_measurements.py) and writes docs/recovery_speed.md, and its
section."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.core.host import machine
from app.jobs.recovery.reproduce.speed_measurements import PARTS as SPEED_RUNS
from app.jobs.recovery.reproduce.table2_damages import SCENARIOS


# the parts of `reproduce recovery-speed` (speed.PARTS and the measurements of speed.measure)
_SPEED_PARTS = "|".join(["bench", "profile", "pairs", "scaling", "variants", "throughput", "check",
                          "perturbed"] + list(SPEED_RUNS))


class SpeedParams(BaseModel):
    parts: str = Field("bench,profile,pairs,scaling,variants,throughput,cap,check,fast,equal,paper,coarse",
                       pattern=rf"^({_SPEED_PARTS})(,({_SPEED_PARTS}))*$",
                       description="what to measure: the recovery bench (the issue's targets); the step profile; "
                                   "explicit contact pairs against the broad phase (CPU time, documented answers); "
                                   "where the paper DE's time goes (inside the rollout or not; thread scaling); "
                                   "physics settings tried (CPU time, what "
                                   "they do to the documented answers); raw and evaluator steps/s; the cut walks' "
                                   "speed cap on random walks; cut walks on every documented damage (same answers?); "
                                   "the random-search control with cut walks against full walks (same best?); "
                                   "coarse-to-fine's coarse search judged at the default step; the fast preset's time "
                                   "to the target; the equal-quality configuration; the paper DE with cut walks "
                                   "(checked against Table II); alt_<name>: another configuration of about the "
                                   "equal-quality budget (speed.ALTERNATIVES); perturbed: the short walks' answers, "
                                   "their same-steps control's and the paper DE's under the named cases and on the "
                                   "held-out models (every seed that has all three)")
    seeds: int = Field(3, ge=1, le=20, description="seeds per damage")
    damages: str = Field("table2", pattern=r"^(table2|1-6|3-4)$", description="table2: the four Table II damages; "
                                                                              "1-6: legs 1 & 6 only; 3-4: legs 3 & 4 only")
    out: Path = Field(Path("docs/recovery_speed.md"), description="markdown to write")
    raw: Path = Field(Path("docs/recovery_speed.json"), description="every run; runs already there are not run again")


def _speed(p: SpeedParams, log: Callable[[str], None]) -> str:
    from app.jobs.recovery.reproduce import speed_measurements as speed

    damages = {"table2": SCENARIOS, "1-6": [(1, 6)], "3-4": [(3, 4)]}[p.damages]
    if "bench" in p.parts.split(","):
        from app.jobs.recovery.reproduce.bench import bench_recovery

        before = os.getloadavg()[0]
        figures = bench_recovery(log=log)
        speed.append_part(p.raw, {"part": "bench", "figures": figures, "load_before": before,
                                  "load_after": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()})
    rows = speed.measure(p.parts.split(","), p.seeds, damages, p.raw, Path("docs"), log=log)
    md = speed.speed_markdown(rows, Path("docs"))
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(speed.page(md))
    return md


def render_speed(datas: list) -> str:
    """docs/recovery_speed.md's generated section (speed.render: from docs/recovery_speed.json and docs/table2.json)."""
    from app.jobs.recovery.reproduce import speed_measurements as speed

    return speed.render(datas)

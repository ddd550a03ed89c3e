"""The paper's six tilting-platform cases (Sec. 5.2, Fig. 6): climbing (y ccw), descending
(y cw) and the steep lateral slope, with legs 1-3-5 and with legs 2-4-6 in stance, each run
without and with recovery. ``gaitmend reproduce tipping`` prints the table in
docs/tipping.md."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.base import BenchEntry, Experiment
from app.stability.scenario import ControllerConfig, TiltScenario, paper_direction, run_summary, run_tilt

PAPER_CASES = (  # (axis, direction, stance, the paper's adjustment leg)
    ("y", "ccw", (1, 3, 5), 6), ("y", "cw", (1, 3, 5), 4), ("x", "ccw", (1, 3, 5), 2),
    ("y", "ccw", (2, 4, 6), 3), ("y", "cw", (2, 4, 6), 1), ("x", "cw", (2, 4, 6), 5),
)


def paper_cases(duration_s: float = 25.0) -> list[dict]:
    rows = []
    for axis, direction, stance, paper_leg in PAPER_CASES:
        # The job's defaults (app/jobs/tipping/spec.py): friction 1.5, threshold 20 deg, ...
        sc = TiltScenario(downhill_deg=paper_direction(axis, direction), stance=stance)
        base, rec = (run_summary(run_tilt(sc, ControllerConfig(recovery=r), duration_s, friction=1.5, record_qpos=False),
                                 ControllerConfig().threshold_deg) for r in (False, True))
        rows.append({"case": f"{axis} {direction}, stance {''.join(map(str, stance))}", "paper_leg": paper_leg,
                     "tipped_without": base["tipped"], "tipped_without_at_s": base["tipped_at_s"],
                     "tipped_with": rec["tipped"], "detection_time_s": rec.get("detection_time_s"),
                     "edge": rec.get("tipping_edge"), "leg": rec.get("adjustment_leg"),
                     "foothold_body_m": rec.get("foothold_body_m"), "time_to_tip_s": rec.get("time_to_tip_s"),
                     "adjustment_time_s": rec.get("adjustment_time_s"),
                     "margin_at_detection_deg": rec.get("margin_at_detection_deg"),
                     "margin_before_deg": rec.get("margin_before_landing_deg"),
                     "margin_after_deg": rec.get("margin_after_landing_deg"),
                     "final_margin_deg": rec["final_margin_deg"], "static_tip_deg": rec.get("static_tip_deg"),
                     "max_tilt_deg": rec.get("max_tilt_deg"), "control_ms_mean": rec["control_ms_mean"]})
    return rows


def markdown(rows: list[dict]) -> str:
    head = ("| case | detected (s) | edge | leg (paper) | foothold body (m) | t_s Eq.15 (s) | swing (s) "
            "| margin at detection / before landing / after (deg) | no recovery | recovery |\n|---|---|---|---|---|---|---|---|---|---|\n")
    def n(v, fmt):  # a run too short to detect anything leaves these empty
        return "-" if v is None else fmt.format(v)

    out = []
    for r in rows:
        fh = "(" + ", ".join(f"{v:.2f}" for v in r["foothold_body_m"]) + ")" if r["foothold_body_m"] else "-"
        without = f"tips at {r['tipped_without_at_s']:.1f} s" if r["tipped_without"] else "stays up"
        out.append(f"| {r['case']} | {n(r['detection_time_s'], '{:.2f}')} | {r['edge'] or '-'} | "
                   f"{r['leg'] or '-'} ({r['paper_leg']}) | {fh} "
                   f"| {n(r['time_to_tip_s'], '{:.2f}')} | {n(r['adjustment_time_s'], '{:.2f}')} | "
                   f"{n(r['margin_at_detection_deg'], '{:.1f}')} / "
                   f"{n(r['margin_before_deg'], '{:.1f}')} / {n(r['margin_after_deg'], '{:.1f}')} "
                   f"| {without} | {'tips' if r['tipped_with'] else 'stays up'} |")
    return head + "\n".join(out)


class CasesParams(BaseModel):
    duration_s: float = Field(25.0, gt=1.0, le=120.0, description="simulated seconds per run")
    out: Path | None = Field(None, description="also write the markdown table here")
    json_out: Path | None = Field(None, description="also write the rows as JSON here")


def cases(p: CasesParams, log: Callable[[str], None]) -> str:
    rows = paper_cases(p.duration_s)
    md = markdown(rows)
    if p.out:
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(md + "\n")
    if p.json_out:
        p.json_out.write_text(json.dumps(rows, indent=1))
    return md


EXPERIMENTS = [Experiment("cases", "The paper's six tilting-platform cases (Sec. 5.2, Fig. 6), each without and "
                                   "with recovery", CasesParams, cases)]


def _bench(quick: bool, log: Callable[[str], None]) -> dict:
    from app.stability.bench import bench_tipping

    return bench_tipping(steps=100 if quick else 500)


BENCH = [BenchEntry("tipping", "FASM + judgment + QP per control step", _bench)]

"""Stored answers judged again on today's perturbed worlds, with no search (issue 47).

A row of docs/table2.json or of the robust comparisons (docs/recovery_robust*.json) keeps
its answer's parameters and the robustness block its job wrote: each named case's walk and
verdict. When a case's world changes (issue 47: the rough floor's grid went from 4 cm to
50 cm, as MuJoCo's height-field collider needs), the searches stay valid (they walk the
nominal model only) and only those case entries are stale. ``rejudge_rows`` walks every
row's answer again under the named cases asked for, on the row's damage and step, as the
job's robustness block walks its answer (one batched rollout per damage and step), replaces
those entries, recounts ``met`` and marks the row with ``rejudged``: the cases and why.
Before it writes anything, it re-walks the answer on the nominal model, and it leaves a row
whose walk is not the stored one (``SAME_WALK``: another answer, or other physics) as it
was, unmarked."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.recovery.cases import walking_cases
from app.jobs.recovery.metrics import target_met
from app.jobs.recovery.robust import MultiModelEvaluator, case_models
from app.jobs.recovery.run import set_up
from app.jobs.recovery.spec import RecoverySpec

FILES = ("docs/table2.json", "docs/recovery_robust.json", "docs/recovery_robust_w20.json")
# The nominal walk that says the row's answer is walked as stored: 0.1 mm, 0.01 deg (a walk of
# another answer or of changed physics moves more; floating-point order in a batch, far less)
SAME_WALK = {"x_f_m": 1e-4, "y_f_m": 1e-4, "yaw_f_deg": 0.01}
# The commit that moved the rough floor (the named case and every random model's) from a 4 cm
# to a 50 cm grid: a ledger run finished before it walked the old floor
FLOOR_CHANGE = {"commit": "855924b", "at": "2026-12-05T09:25:14Z"}
WHY = "issue 47: the rough floor's grid is now 50 cm; on the old 4 cm grid a flat floor alone changed the walk"


def _key(row: dict) -> tuple:
    return tuple(row["lost_legs"]), float(row["timestep_s"])


def rejudge_rows(rows: list[dict], cases: Sequence[str], why: str = WHY,
                 log: Callable[[str], None] = print) -> tuple[int, list[dict]]:
    """Rewrites ``cases`` in every row's robustness block (in place); returns (the rows
    rewritten, the rows left alone because their answer no longer walks as stored). Rows
    without parameters or a robustness block are not counted."""
    skipped: list[dict] = []
    todo = [r for r in rows if r.get("best_params") and r.get("robustness", {}).get("cases")]
    groups: dict[tuple, list[dict]] = {}
    for r in todo:
        groups.setdefault(_key(r), []).append(r)
    for (lost, dt), group in groups.items():
        job = set_up(RecoverySpec(damage={"lost_legs": list(lost)}, sim={"timestep_s": dt},
                                  robustness={"cases": [], "held_out": 0}, controls={"random_search": False}))
        walk_s = job.spec.sim.duration_s
        named = walking_cases(job.robot.geometry.total_mass, cases)
        ev = MultiModelEvaluator(job.robot, [job.model] + case_models(job.mspec, job.model, named), job.seq,
                                 job.ev.cfg)
        try:
            x = np.array([list(r["best_params"].values()) for r in group])
            m = ev.evaluate_all(x).metrics
        finally:
            ev.close()
            job.close()
        for i, r in enumerate(group):
            off = {key: (float(m[key][i, 0]), r["best"][key]) for key, tol in SAME_WALK.items()
                   if abs(m[key][i, 0] - r["best"][key]) > tol}
            if off:
                skipped.append(r)
                log(f"legs {list(lost)} {r.get('mode', '')} seed {r.get('seed')} at {dt * 1000:g} ms: not the stored "
                    f"walk on the nominal model (walked, stored: {off}); left as it is")
                continue
            block = r["robustness"]["cases"]
            for k, c in enumerate(named, start=1):
                keep = [key for key in (block.get(c.name) or {"x_f_m": 0, "y_f_m": 0, "yaw_f_deg": 0, "fell": 0})
                        if key != "target_met"]
                walked = {key: (bool(m[key][i, k]) if key == "fell" else float(m[key][i, k])) for key in keep}
                block[c.name] = walked | {"target_met": target_met(walked, walk_s)}
            r["robustness"]["met"] = sum(bool(v["target_met"]) for v in block.values())
            r["robustness"]["total"] = len(block)
            r["rejudged"] = {"cases": list(cases), "why": why}
        log(f"legs {list(lost)} at {dt * 1000:g} ms: {len(group)} answers walked under {', '.join(cases)}")
    return len(todo) - len(skipped), skipped


class RejudgeParams(BaseModel):
    files: str = Field(",".join(FILES), description="comma-separated JSON files of rows to rewrite in place")
    cases: str = Field("rough_terrain", description="comma-separated named cases to walk again")


def run_rejudge(p: RejudgeParams, log: Callable[[str], None]) -> str:
    out = []
    for name in p.files.split(","):
        path = Path(name)
        rows = json.loads(path.read_text())
        n, skipped = rejudge_rows(rows, p.cases.split(","), log=log)
        tmp = path.with_suffix(".part")
        tmp.write_text(json.dumps(rows, indent=1))
        tmp.replace(path)
        out.append(f"- {path}: {n} answers re-walked under {p.cases}"
                   + (f"; {len(skipped)} left as they were (no longer the stored walk on the nominal model)"
                      if skipped else ""))
    return "\n".join(out + ["", "`gaitmend docs` renders the pages from the rewritten files."]) + "\n"


def rejudged_note(rows: list[dict], name: Callable[[dict], str]) -> list[str]:
    """The pages' sentence on rows walked again under some cases (none: nothing), naming with
    ``name`` the rows whose entries are still the old ones."""
    done = [r for r in rows if r.get("rejudged")]
    if not done:
        return []
    cases = sorted({c for r in done for c in r["rejudged"]["cases"]})
    left = [r for r in rows if not r.get("rejudged") and r.get("robustness", {}).get("cases")]
    text = (f"The {', '.join(cases)} entries of {len(done)} of {len(done) + len(left)} answers were walked again, "
            f"with no search, by `gaitmend reproduce recovery-rejudge` ({done[0]['rejudged']['why']}).")
    if left:
        text += (" Still the old floor's: " + "; ".join(name(r) for r in left) + " (the answer no longer walks as "
                 "stored on the nominal model, so it was not walked again).")
    return [text, ""]


def old_floor(runs: list[dict]) -> list[dict]:
    """The ledger runs that finished before ``FLOOR_CHANGE`` (their rough floor was 4 cm)."""
    return [r for r in runs if r.get("finished_at", "") < FLOOR_CHANGE["at"]]


def old_floor_note(runs: list[dict], what: str, command: str) -> list[str]:
    """The pages' warning, first in their generated section, when their runs walked the old
    floor (none: nothing)."""
    old = old_floor(runs)
    if not old:
        return []
    return [f"**Measured on the old floor.** {len(old)} of {len(runs)} runs here finished before commit "
            f"{FLOOR_CHANGE['commit']} (issue 47), on a rough floor of a 4 cm height-field grid, where MuJoCo's "
            f"prism-by-prism contacts changed a walk on a flat floor as much as the roughness did: {what} are that "
            f"floor's, not today's 50 cm one's. `{command}` measures them again.", ""]

"""docs/robots.md's "Measured" table, rendered from docs/robot_figures.json (issue 28: every
published number from committed data): ``scripts/robot_figures.py --json-out
docs/robot_figures.json`` appends each run with the machine, its load, the commit and the
date; the page shows the latest."""

from __future__ import annotations

from app.core.host import machine_text
from app.jobs.reporting import Section, md_table, missing
from app.results.examples import commit_text

JSON = "docs/robot_figures.json"
COMMAND = ".venv/bin/python scripts/robot_figures.py --json-out docs/robot_figures.json"

ROWS = [("prepare_ant_s", "upload to stored robot (pre-parse + confined compile + detection; `prepare`), gymnasium ant"),
        ("prepare_dm_quadruped_s", "the same, dm_control quadruped with its three included files and height field"),
        ("cli_add_ant_s", "`gaitmend robot add ant.xml --json` end to end (CLI start, imports, database), "
                          "a fresh data folder each time"),
        ("ik_jethexa_30x600_s", "IK, JetHexa, population 30 x one gait period (600 samples at 1 ms) x 6 legs"),
        ("ik_jethexa_30x150_s", "IK, JetHexa, 30 x 150 samples x 6 legs"),
        ("ik_ant_30x600_s", "IK, gymnasium ant, 30 x 600 x 4 legs")]


def _times(ts: list[float]) -> str:
    s = sorted(ts)
    return f"{s[0]:.2f} s (median {s[len(s) // 2]:.2f} s)"


def render(data: dict | None) -> str:
    runs = (data or {}).get("runs", [])
    if not runs:
        return missing(JSON, COMMAND)
    r = runs[-1]
    f = r["figures"]
    rows = []
    for key, what in ROWS:
        extra = f", {f[key.removesuffix('_s') + '_iterations']} iterations" if key.startswith("ik_jethexa") else ""
        rows.append([what, _times(f[key]) + extra])
    rates = f["mj_step_per_s"]
    rows.append([f"raw `mj_step` rate from Python, one step a call: {' / '.join(rates)}",
                 " / ".join(f"{v:,.0f}" for v in rates.values()) + " steps/s"])
    m = r["machine"]
    return (md_table(["what", f"time, best of {r['repeats']}"], rows)
            + f"\nMeasured {r['date']} on {machine_text(m)}, nice {r['nice']}, 1-minute load "
              f"{r['load_before']:.1f} before and {r['load_after']:.1f} after (other work on the machine makes "
              f"these upper bounds), commit {commit_text(r)}. "
              f"{len(runs) - 1} earlier run{'' if len(runs) == 2 else 's'} kept in "
              f"[{JSON.split('/')[-1]}]({JSON.split('/')[-1]}).\n")


def sections() -> tuple[Section, ...]:
    return (Section("robot-figures", (JSON,), lambda d: render(d[0])),)

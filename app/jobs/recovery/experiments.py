"""Paper 000, Table II in simulation: four damage scenarios over several seeds."""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.base import Experiment, MemoryContext
from app.jobs.recovery.present import TARGET
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import RecoverySpec

SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]
# Table II of the paper (real robot, mean of 10 best solutions): x, y in cm, yaw in deg.
PAPER = {
    (1, 6): {"before": None, "after": (-9.3, 28.1, -19.5)},
    (3, 4): {"before": (-2.3, 1.5, 2.4), "after": (10.1, 52.7, 5.8)},
    (1,): {"before": None, "after": (-4.1, 69.5, -4.3)},
    (4,): {"before": (14.6, 26.6, 64.0), "after": (9.4, 66.9, 13.0)},
}


def run_scenarios(seeds: int, generations: int, population: int, log: Callable[[str], None] = print,
                  raw_path: Path | None = None) -> list[dict]:
    """Runs every (scenario, seed). With raw_path, each finished run is appended to that
    JSON file at once, and runs already there (same budget) are not run again: an
    interrupted reproduction resumes where it stopped."""
    rows = []
    if raw_path is not None and raw_path.exists():
        rows = [r for r in json.loads(raw_path.read_text())
                if r.get("generations") == generations and r.get("population") == population]
    done = {(tuple(r["lost_legs"]), r["seed"]) for r in rows}
    for lost in SCENARIOS:
        for seed in range(seeds):
            if (lost, seed) in done:
                continue
            spec = RecoverySpec(damage={"lost_legs": list(lost)},
                                search={"population": population, "generations": generations, "seed": seed})
            t = time.perf_counter()
            s = run(spec, MemoryContext()).summary
            rows.append({"lost_legs": list(lost), "seed": seed, "generations": generations, "population": population,
                         "baseline": s["baseline"]["metrics"], "best": s["best"]["metrics"],
                         "best_fitness": s["best"]["fitness"], "gait": s["gait"]["name"],
                         "wall_s": s["timing"]["wall_s"]})
            if raw_path is not None:
                raw_path.parent.mkdir(parents=True, exist_ok=True)
                tmp = raw_path.with_suffix(".part")
                tmp.write_text(json.dumps(rows, indent=1))
                tmp.replace(raw_path)
            m = s["best"]["metrics"]
            log(f"legs {lost} seed {seed}: x {100 * m['x_f_m']:.1f} cm, y {100 * m['y_f_m']:.1f} cm, "
                f"yaw {m['yaw_f_deg']:.1f} deg ({time.perf_counter() - t:.0f} s)")
    return rows


def _median(rows, key):
    return statistics.median(r["best"][key] for r in rows)


def table_markdown(rows: list[dict], generations: int, population: int) -> str:
    seeds = len({r["seed"] for r in rows})
    out = [
        f"Simulated Table II: JetHexa-like model, DE {population} x {generations}, 10 s walks, up to "
        f"{seeds} seeds per scenario (column 'seeds'); after-recovery columns are medians "
        "over seeds [min, max]. Before = the nominal tripod on the damaged robot (deterministic).",
        "",
        "| damage | gait | seeds | before x (cm) | before y (cm) | before yaw (deg) | after x (cm) | after y (cm) "
        "| after yaw (deg) | fell after | target met | paper after x / y / yaw |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for lost in SCENARIOS:
        rs = [r for r in rows if tuple(r["lost_legs"]) == lost]
        if not rs:
            continue
        b = rs[0]["baseline"]
        before = ("fell", "fell", "fell") if b["fell"] else (
            f"{100 * b['x_f_m']:.1f}", f"{100 * b['y_f_m']:.1f}", f"{b['yaw_f_deg']:.1f}")

        def cell(key, scale):
            vals = [scale * r["best"][key] for r in rs]
            return f"{statistics.median(vals):.1f} [{min(vals):.1f}, {max(vals):.1f}]"

        ok = (_median(rs, "y_f_m") >= TARGET["y_min_m"] and abs(_median(rs, "x_f_m")) <= TARGET["x_abs_max_m"]
              and abs(_median(rs, "yaw_f_deg")) <= TARGET["yaw_abs_max_deg"])
        p = PAPER[lost]["after"]
        name = ("Legs " if len(lost) > 1 else "Leg ") + " & ".join(str(l) for l in lost) + " lost"
        out.append(f"| {name} | {rs[0]['gait']} | {len(rs)} | {before[0]} | {before[1]} | {before[2]} | {cell('x_f_m', 100)} | "
                   f"{cell('y_f_m', 100)} | {cell('yaw_f_deg', 1)} | {sum(r['best']['fell'] for r in rs)}/{len(rs)} | "
                   f"{'yes' if ok else 'no'} | {p[0]} / {p[1]} / {p[2]} |")
    walls = [r["wall_s"] for r in rows]
    out += ["", f"Target (issue): median forward >= 50 cm, |lateral| <= 5 cm, |yaw| <= 10 deg. "
                f"Wall time per run: median {statistics.median(walls):.0f} s.", ""]
    return "\n".join(out)


def run_table2(seeds: int, generations: int, population: int, log: Callable[[str], None] = print,
               raw_path: Path | None = Path("docs/table2.json")) -> str:
    rows = run_scenarios(seeds, generations, population, log, raw_path)
    rows = [r for r in rows if r["seed"] < seeds]
    return table_markdown(rows, generations, population)


class Table2Params(BaseModel):
    seeds: int = Field(10, ge=1, le=100, description="seeds per scenario")
    generations: int = Field(60, ge=1, le=10000, description="DE generations (paper: 60)")
    population: int = Field(30, ge=4, le=1000, description="DE population (paper: 30)")
    out: Path = Field(Path("docs/table2.md"), description="markdown table to write")
    raw: Path = Field(Path("docs/table2.json"), description="per-run rows; runs already there are not run again")


def _table2(p: Table2Params, log: Callable[[str], None]) -> str:
    md = run_table2(seeds=p.seeds, generations=p.generations, population=p.population, log=log, raw_path=p.raw)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(md)
    return md


EXPERIMENTS = [Experiment("table2", "Paper 000's Table II scenarios (legs 1&6, 3&4, 1, 4 lost) over seeds; "
                                    "writes the table", Table2Params, _table2)]

"""The damage atlas as committed data (issue 28): every feasible 1- and 2-leg loss of the
hexapod searched at the paper's budget (DE 30 x 60, 10 s walks) at the default step, with the
seven robustness re-runs, over seeds. `gaitmend reproduce recovery-atlas --write-docs`
appends each finished (loss, seed) to docs/recovery_atlas.json the moment it ends; a re-run
skips those already there at this code version, so the atlas can be filled over sessions.

The four Table II damages are not searched again: their rows are docs/table2.json's (the same
search, spec and seeds, run with the random-search control besides), read when the page is
rendered. The atlas runs have no random-search control (it would double each point's cost);
Table II is where DE is compared with it. docs/recovery_atlas.md is rendered from both files
(``render``): nothing on that page is typed.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger, current_runs, machine_time
from app.jobs.recovery.reproduce import curves, science_files
from app.jobs.recovery.reproduce.rows import KEEP, feasible_losses, leg_losses, search_row
from app.jobs.reporting import md_table, missing, progress_note

JSON = "docs/recovery_atlas.json"
TABLE2_JSON = "docs/table2.json"
COMMAND = "gaitmend reproduce recovery-atlas --write-docs"
SCIENCE = science_files.BASE
TABLE2 = ((1, 6), (3, 4), (1,), (4,))  # their rows come from Table II (experiments.SCENARIOS)


class AtlasParams(BaseModel):
    seeds: int = Field(2, ge=1, le=10, description="seeds per loss (0 .. seeds-1), run seed by seed")
    population: int = Field(30, ge=4, le=1000, description="DE population (paper: 30)")
    generations: int = Field(60, ge=1, le=10000, description="DE generations after the first (paper: 60)")
    json_out: Path | None = Field(Path(JSON), description="the ledger: each (loss, seed) is appended when it ends")


def atlas_losses() -> list[tuple[int, ...]]:
    """The feasible 1- and 2-leg losses the atlas searches (Table II's four come from Table II)."""
    return [lost for lost in feasible_losses() if lost not in TABLE2]


def _spec(lost: tuple[int, ...], seed: int, population: int, generations: int) -> dict:
    return {"damage": {"lost_legs": list(lost)}, "controls": {"random_search": False},
            "search": {"population": population, "generations": generations, "seed": seed}}


def search_one(lost: tuple[int, ...], seed: int, population: int, generations: int) -> dict:
    """One atlas point: the job's search with its baseline and robustness block, as a row of
    the same fields as Table II's (experiments._row; no random-search control)."""
    from app.jobs.base import MemoryContext
    from app.jobs.recovery.run import run
    from app.jobs.recovery.spec import RecoverySpec

    s = run(RecoverySpec(**_spec(lost, seed, population, generations)), MemoryContext()).summary
    return search_row(lost, seed, generations, population, s)


def run_atlas(p: AtlasParams, log: Callable[[str], None] = print) -> str:
    """Seed by seed (a cut-short atlas still has every loss), each loss not in the ledger."""
    losses = atlas_losses()
    led = Ledger(p.json_out, "recovery-atlas", COMMAND, p.model_dump(mode="json"), SCIENCE,
                 planned=len(losses) * p.seeds)
    for seed in range(p.seeds):
        for lost in losses:
            name = f"legs {'-'.join(map(str, lost))} seed {seed}"
            spec = _spec(lost, seed, p.population, p.generations)
            if led.find(spec, seed) is None:
                log(f"{name}: searching (DE {p.population} x {p.generations + 1} walks, robustness block)")
            led.run(name, spec, seed, lambda: search_one(lost, seed, p.population, p.generations), log)
    return (f"{len(current_runs(led.data))} of {led.data['planned']} planned atlas runs in {p.json_out} "
            f"(code {led.version}); machine time {machine_time(led.data)['wall_s']:.0f} s wall.\n")


# -- the page ---------------------------------------------------------------------------------

def _rows(atlas: dict | None, table2: list | None) -> tuple[list[dict], dict]:
    """Every answer at the atlas's budget and the default step: the atlas's runs and Table II's
    rows of the same budget, step and seeds (seed < the atlas's seeds); and the atlas's params."""
    from app.jobs.recovery.spec import RecoverySpec

    params = (atlas or {}).get("params") or AtlasParams().model_dump(mode="json")
    dt = RecoverySpec().sim.timestep_s
    rows = [r["result"] for r in current_runs(atlas)] if atlas else []
    rows = [r | {"source": "atlas"} for r in rows if r["timestep_s"] == dt]
    for r in table2 or []:
        if (tuple(r["lost_legs"]) in TABLE2 and r["timestep_s"] == dt and r["seed"] < params["seeds"]
                and r["population"] == params["population"] and r["generations"] == params["generations"]):
            rows.append(r | {"source": "Table II"})
    return rows, params


def _mmm(xs: list[float], scale: float = 1.0) -> str:
    xs = [scale * x for x in xs]
    return f"{statistics.median(xs):.1f} [{min(xs):.1f}, {max(xs):.1f}]"


def _name(lost: tuple[int, ...]) -> str:
    return ", ".join(map(str, lost))


def _said(lost: tuple[int, ...]) -> str:
    return ("legs " if len(lost) > 1 else "leg ") + " & ".join(map(str, lost))


def _groups(rows: list[dict]) -> dict[tuple[int, ...], list[dict]]:
    out: dict[tuple[int, ...], list[dict]] = {}
    for r in sorted(rows, key=lambda r: r["seed"]):
        out.setdefault(tuple(r["lost_legs"]), []).append(r)
    return dict(sorted(out.items(), key=lambda kv: (len(kv[0]), kv[0])))


def _table(groups: dict[tuple[int, ...], list[dict]]) -> str:
    body = []
    for lost, rs in groups.items():
        best = [r["best"] for r in rs]
        body.append([_name(lost), len(rs), rs[0]["source"], _mmm([m["y_f_m"] for m in best], 100),
                     _mmm([m["x_f_m"] for m in best], 100), _mmm([m["yaw_f_deg"] for m in best]),
                     f"{sum(r['target_met'] is True for r in rs)}/{len(rs)}", sum(m["fell"] for m in best),
                     "**yes**" if rs[0]["baseline_target_met"] else "no",
                     ", ".join(str(r["robustness"]["met"]) for r in rs)])
    return md_table(["lost legs", "seeds", "data", "forward (cm)", "lateral (cm)", "yaw (deg)", "target met",
                     "fell", "baseline meets it", "perturbed re-runs meeting it (of 7, per seed)"], body)


def _convergence(rows: list[dict]) -> str:
    """The convergence rule over every answer, each re-run at half its step by its robustness block."""
    from app.jobs.recovery.reproduce.convergence import RULE_TEXT, check, halving_deltas

    have = [r for r in rows if "dt_half" in r["robustness"]["cases"]]
    if not have:
        return ""
    keys = ("x_f_m", "y_f_m", "yaw_f_deg")
    v = check(halving_deltas({k: np.array([r["best"][k] for r in have]) for k in keys},
                             {k: np.array([r["robustness"]["cases"]["dt_half"][k] for r in have]) for k in keys}))
    return (f"Convergence rule ({RULE_TEXT}) over these {v['answers']} answers, each re-run at half the step by its "
            f"robustness block: {'**passes**' if v['passes'] else '**fails**'}; forward moves at most "
            f"{100 * v['max_forward_rel']:.1f} %, {100 * v['share_within']:.0f} % of the answers stay within the drift "
            f"and yaw bands (median change {100 * v['median_lateral_m']:.1f} cm, {v['median_yaw_deg']:.1f} deg; "
            f"largest {100 * v['max_lateral_m']:.1f} cm, {v['max_yaw_deg']:.1f} deg).\n")


def _findings(groups: dict[tuple[int, ...], list[dict]]) -> list[str]:
    """What the table shows, counted from it."""
    rows = [r for rs in groups.values() for r in rs]
    met = sum(r["target_met"] is True for r in rows)
    missed = [f"{_said(lost)} (seed {r['seed']})" for lost, rs in groups.items() for r in rs
              if r["target_met"] is not True]
    already = [_said(lost) for lost, rs in groups.items() if rs[0]["baseline_target_met"]]
    rob = {n: [r["robustness"]["met"] for lost, rs in groups.items() if len(lost) == n for r in rs] for n in (1, 2)}
    out = [f"- **Recovery meets the target in {met} of {len(rows)} answers**"
           + (f"; missed: {', '.join(missed)}." if missed else ".")]
    out.append(f"- **The nominal tripod already meets the target** for: {', '.join(already)} (no recovery needed "
               "there; the job's baseline says so)." if already else
               "- **The nominal tripod meets the target on no loss**: every loss needs the recovery.")
    for n, word in ((1, "single-leg"), (2, "two-leg")):
        if rob[n]:
            out.append(f"- **Perturbed re-runs** ({word} losses): the answers keep the target in a median of "
                       f"{statistics.median(rob[n]):g} of 7 [{min(rob[n])}, {max(rob[n])}].")
    return out


def render(datas: list) -> str:
    """docs/recovery_atlas.md's generated section, from docs/recovery_atlas.json and docs/table2.json."""
    atlas, table2 = datas
    rows, params = _rows(atlas, table2)
    if not rows:
        return missing(JSON, COMMAND)
    groups = _groups(rows)
    mt = machine_time(atlas) if atlas else {"runs": 0, "wall_s": 0.0}
    dt = rows[0]["timestep_s"]
    infeasible = leg_losses()[1]
    paper = params["population"] == 30 and params["generations"] == 60
    from app.jobs.recovery.reproduce.rejudge import old_floor_note

    stale = old_floor_note(current_runs(atlas) if atlas else [],
                           "the rough_terrain entries of the atlas's own runs (one of the 7 perturbed re-runs counted "
                           "per seed; Table II's rows were walked again on today's floor by `gaitmend reproduce "
                           "recovery-rejudge`)", COMMAND)
    out = stale + [f"Every point: DE {params['population']} x ({params['generations']} + 1) walks of 10 s at "
           f"{1000 * dt:g} ms ({'the paper' if paper else 'not the paper'}'s budget), seeds 0-{params['seeds'] - 1}, the seven "
           "robustness re-runs, no random-search control. Column 'data': the atlas's own runs (recovery_atlas.json: "
           f"{mt['runs']} run{'' if mt['runs'] == 1 else 's'}, {mt['wall_s'] / 3600:.1f} h wall on this project's shared 2-core machine), or for "
           "Table II's four damages that table's runs of the same search and seeds (table2.json; Table II pairs them "
           "with the random-search control). Target: forward >= 50 cm, |lateral| <= 5 cm, |yaw| <= 10 deg, no "
           "fall. Values: median [min, max] over the seeds.", "", _table(groups), _convergence(rows)]
    out += _findings(groups)
    out += ["", curves.render_generations([r for r in rows if r["source"] == "atlas"], JSON, COMMAND)]
    if infeasible:
        out += ["", "Infeasible, listed and never run: " + "; ".join(
            f"{', '.join(map(_said, losses))} ({why})" for why, losses in infeasible.items()) + "."]
    note = progress_note(atlas, mt["runs"]) if atlas else f"\n*No atlas runs yet: `{COMMAND}` writes {JSON}.*\n"
    return "\n".join(out) + "\n" + note

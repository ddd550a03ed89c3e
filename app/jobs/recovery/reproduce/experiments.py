"""Paper 000's experiments and the recovery evidence: Table II in simulation (every row a
real run of this code), robust vs nominal recovery on every feasible 1- and 2-leg loss,
the baselines that need no recovery, and the timestep convergence study.

Table II and the robust comparison live here with ``EXPERIMENTS``; the baselines, the
convergence study and the speed measurements are in baselines_check.py,
convergence_check.py and speed_experiment.py, beside peers_check.py, atlas_check.py,
loop_check.py and randomised_check.py; table2_damages.py holds what they share."""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field, field_validator

from app.jobs.base import Experiment, MemoryContext
from app.jobs.recovery.reproduce import (atlas_check, choice_check, curves, jobtime, loop_check, peers_check,
                                         page_prose, randomised_check, recommended_check, rejudge)
from app.jobs.reporting import Section, marked, missing
from app.jobs.evidence import controls_of
from app.jobs.recovery.reproduce.documented_answers import documented_answers  # noqa: F401 (re-exported for the tests)
from app.jobs.recovery.reproduce.rows import feasible_losses, robustness_row, search_row
from app.jobs.recovery.metrics import TARGET
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.table2_damages import SCENARIOS, _name, _save_rows
from app.jobs.recovery.reproduce.baselines_check import BASELINES_JSON, BaselinesParams, _baselines, render_baselines
# besides the experiments' entries, convergence_report and SpeedParams are re-exported for the tests
from app.jobs.recovery.reproduce.convergence_check import (CONVERGENCE_JSON, CONVERGENCE_SECTIONS, ConvergenceParams,
                                                           _convergence, convergence_report, render_convergence_answers,
                                                           render_convergence_table)
from app.jobs.recovery.reproduce.speed_experiment import SpeedParams, _speed, render_speed


# Paper 000's Table II, quoted: the paper's numbers, not ours (its real robot, mean of the 10 best
# solutions): x, y in cm, yaw in deg; before None: N/A in the paper, its robot fell before recovery.
PAPER = {
    (1, 6): {"before": None, "after": (-9.3, 28.1, -19.5)},
    (3, 4): {"before": (-2.3, 1.5, 2.4), "after": (10.1, 52.7, 5.8)},
    (1,): {"before": None, "after": (-4.1, 69.5, -4.3)},
    (4,): {"before": (14.6, 26.6, 64.0), "after": (9.4, 66.9, 13.0)},
}


ROW_VERSION = 2  # rows from a real run of this code: params, controls, robustness (no transcribed rows)


def _row(lost, seed, generations, population, s: dict) -> dict:
    rs = next((c for c in controls_of(s) if c.name == "random_search"), None)
    return {"version": ROW_VERSION} | search_row(lost, seed, generations, population, s) | {
        "random_search": None if rs is None else {"metrics": rs.metrics, "fitness": rs.extra["fitness"],
                                                  "target_met": rs.target_met},
        "wall_s": s["timing"]["wall_s"]}


def run_scenarios(seeds: int, generations: int, population: int, log: Callable[[str], None] = print,
                  raw_path: Path | None = None, scenarios=None) -> list[dict]:
    """Runs every (scenario, seed), seed by seed (so a cut-short reproduction still has
    every scenario). With raw_path, each finished run is written to that JSON file at once
    and runs already there (same budget and timestep) are not run again: an interrupted
    reproduction resumes where it stopped. Rows of another format are dropped; rows of
    another budget or timestep stay in the file (earlier measurements) and are not tabled."""
    timestep = RecoverySpec().sim.timestep_s
    rows, others = _rows_in(raw_path, lambda r: r.get("generations") == generations
                            and r.get("population") == population and r.get("timestep_s") == timestep,
                            keep=lambda r: r.get("version") == ROW_VERSION)
    done = {(tuple(r["lost_legs"]), r["seed"]) for r in rows}
    for seed in range(seeds):
        for lost in scenarios or SCENARIOS:
            if (lost, seed) in done:
                continue
            spec = RecoverySpec(damage={"lost_legs": list(lost)},
                                search={"population": population, "generations": generations, "seed": seed})
            s, wall = _run_and_keep(spec, lambda s: _row(lost, seed, generations, population, s), rows, others,
                                    raw_path)
            m = s["best"]["metrics"]
            log(f"legs {lost} seed {seed}: x {100 * m['x_f_m']:.1f} cm, y {100 * m['y_f_m']:.1f} cm, "
                f"yaw {m['yaw_f_deg']:.1f} deg, robustness {rows[-1]['robustness']['met']}/"
                f"{rows[-1]['robustness']['total']} ({wall:.0f} s)")
    return rows


def _rows_in(raw_path: Path | None, same: Callable[[dict], bool],
             keep: Callable[[dict], bool] = lambda r: True) -> tuple[list[dict], list[dict]]:
    """The rows a resumed reproduction finds in ``raw_path`` (those ``keep`` drops are of an
    old format): (those of this budget, which are not run again; the others, earlier
    measurements kept in the file but not tabled)."""
    rows, others = [], []
    if raw_path is not None and raw_path.exists():
        for r in json.loads(raw_path.read_text()):
            if keep(r):
                (rows if same(r) else others).append(r)
    return rows, others


def _run_and_keep(spec: RecoverySpec, row_of: Callable[[dict], dict], rows: list[dict], others: list[dict],
                  raw_path: Path | None) -> tuple[dict, float]:
    """Runs ``spec``, appends its row (with the machine's 1-minute load before and after
    the run and its cores, so its wall time can be read) and saves at once: (the summary,
    the run's wall time)."""
    before, t = os.getloadavg()[0], time.perf_counter()
    s = run(spec, MemoryContext()).summary
    rows.append(row_of(s) | {"load_before": before, "load_after": os.getloadavg()[0], "cores": os.cpu_count()})
    _save_rows(others + rows, raw_path)
    return s, time.perf_counter() - t


def _median(rows, key):
    return statistics.median(r["best"][key] for r in rows)


def _paper_cell(v) -> str:
    return "fell (N/A)" if v is None else f"{v[0]} / {v[1]} / {v[2]}"


def _scenario_row(lost, rs: list[dict]) -> str:
    """Table II's row of one damage: our before, our after over seeds, the control, the paper's before and after."""
    b = rs[0]["baseline"]
    before = f"{100 * b['x_f_m']:.1f} / {100 * b['y_f_m']:.1f} / {b['yaw_f_deg']:.1f}"
    bflags = f"{'yes' if b['fell'] else 'no'} / {'**yes**' if rs[0]['baseline_target_met'] else 'no'}"

    def cell(key, scale, src="best"):
        vals = [scale * r[src][key] for r in rs]
        return f"{statistics.median(vals):.1f} [{min(vals):.1f}, {max(vals):.1f}]"

    met = sum(r["target_met"] for r in rs)
    rob = statistics.median(r["robustness"]["met"] for r in rs)
    tot = rs[0]["robustness"]["total"]
    rnd = [r["random_search"] for r in rs if r["random_search"] is not None]
    rnd_cell = "not run" if not rnd else (
        f"{statistics.median(100 * c['metrics']['y_f_m'] for c in rnd):.1f}, "
        f"{sum(c['target_met'] for c in rnd)}/{len(rnd)}")
    paper = PAPER[lost]
    return (f"| {_name(lost)} | {rs[0]['gait']} | {len(rs)} | {before} | {bflags} | {cell('x_f_m', 100)} | "
            f"{cell('y_f_m', 100)} | {cell('yaw_f_deg', 1)} | {sum(r['best']['fell'] for r in rs)}/{len(rs)} | "
            f"{met}/{len(rs)} | {rob:g}/{tot} | {rnd_cell} | {_paper_cell(paper['before'])} | "
            f"{_paper_cell(paper['after'])} |")


def _perturbation_table(rows: list[dict]) -> list[str]:
    cases = list(rows[0]["robustness"]["cases"]) if rows else []
    if not cases:
        return []
    out = ["Drift and yaw of the recovered gaits under perturbation (median over seeds of |x| cm / |yaw| deg; "
           "runs meeting the target):", "",
           "| damage | nominal | " + " | ".join(cases) + " |", "|---" * (len(cases) + 2) + "|"]

    def pc(ms, n):
        x = statistics.median(abs(100 * m["x_f_m"]) for m in ms)
        y = statistics.median(abs(m["yaw_f_deg"]) for m in ms)
        ok = sum(m.get("target_met", TARGET.met(m)) for m in ms)
        return f"{x:.1f} / {y:.1f}; {ok}/{n}"

    for lost in SCENARIOS:
        rs = [r for r in rows if tuple(r["lost_legs"]) == lost]
        if rs:
            cells = [pc([r["best"] for r in rs], len(rs))]
            cells += [pc([r["robustness"]["cases"][c] for r in rs], len(rs)) for c in cases]
            out.append(f"| {_name(lost)} | " + " | ".join(cells) + " |")
    return out + [""]


def table_markdown(rows: list[dict], generations: int, population: int, peers: dict | None = None) -> str:
    """The Table II page from Table II's rows (docs/table2.json) and the peers' ledger
    (docs/table2_peers.json, None: not yet run): nothing is simulated here."""
    from app.jobs.recovery.reproduce.peers_check import comparisons_markdown

    if not rows:
        return (f"*No Table II runs of DE {population} x {generations} at the default step in the data yet: "
                "`gaitmend reproduce recovery --write-docs` writes docs/table2.json.*\n")
    seeds = sorted({r["seed"] for r in rows})
    dt = rows[0]["timestep_s"] if rows else RecoverySpec().sim.timestep_s
    out = [
        f"Simulated Table II: JetHexa-like model, DE {population} x {generations}, 10 s walks, timestep "
        f"{1000 * dt:g} ms, seeds {seeds[0]}-{seeds[-1]} (column 'seeds' counts the runs per scenario); every row "
        "was run by `gaitmend reproduce` with this code (none transcribed). After-recovery columns are medians over "
        "seeds [min, max]. Before = the nominal tripod on the damaged robot (deterministic). The paper's columns "
        "are quoted from paper 000's Table II (its real robot, mean of the 10 best solutions; x, y in cm, yaw in "
        "deg), not ours: 'fell (N/A)' where the paper's robot fell before recovery and it gives no numbers. "
        "(The copy's Fig. 12 caption names leg 3 for the last damage; its Table II and text say leg 4, used here.)",
        "",
        "| damage | gait | seeds | before x / y / yaw | before: fell / meets target | after x (cm) | after y (cm) "
        "| after yaw (deg) | fell after | target met (runs) | under perturbation: cases met (median of runs) "
        "| random search, same budget: y (cm), target met | paper before x / y / yaw | paper after x / y / yaw |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for lost in SCENARIOS:
        rs = [r for r in rows if tuple(r["lost_legs"]) == lost]
        if rs:
            out.append(_scenario_row(lost, rs))
    walks = [r["wall_s"] for r in rows]
    with_control = sum(r["random_search"] is not None for r in rows)
    if with_control < len(rows):
        out += ["", f"The random-search control ran in {with_control} of {len(rows)} runs (the others were run with "
                    "`controls.random_search: false` to fit the CPU time available); 'not run' marks the rest."]
    out += ["", f"Target (issue 12): {TARGET.text}. 'fell' = the chassis, a coxa or a femur touched the ground "
                "(MuJoCo contact sensors), or the body tilted past 60 deg or sagged below half its height. "
                f"Wall time per run: median {statistics.median(walks):.0f} s on the machine that ran it "
                "(2 cores, often loaded by other work: a loaded machine makes it longer).", ""]
    out += _perturbation_table(rows)
    out += rejudge.rejudged_note(rows, lambda r: f"{_name(r['lost_legs'])} seed {r['seed']}")
    out += ["### Generations to converge (the paper's Figs. 3, 6, 9, 12)", "",
            curves.render_generations(rows, TABLE2_JSON, "gaitmend reproduce recovery --write-docs"), ""]
    out += ["## Against the controls and the peers, paired", "",
            comparisons_markdown(rows, peers, population, generations, dt), ""]
    return "\n".join(out)


TABLE2_JSON, PEERS_JSON = "docs/table2.json", "docs/table2_peers.json"
TABLE2_SECTION = "recovery-table2"


def _paper_budget(rows: list[dict], generations: int = 60, population: int = 30, any_step: bool = False) -> list[dict]:
    """Table II's rows of this budget, of the current row format, at the default step (every
    step with ``any_step``)."""
    dt = RecoverySpec().sim.timestep_s
    return [r for r in rows if r.get("version") == ROW_VERSION and r.get("generations") == generations
            and r.get("population") == population and (any_step or r.get("timestep_s") == dt)]


def render_table2(datas: list) -> str:
    """docs/table2.md's generated section: Table II at the paper's budget over seeds 0-9 from
    docs/table2.json, paired with the peers' ledger (docs/table2_peers.json)."""
    rows, peers = datas
    return table_markdown([r for r in _paper_budget(rows or []) if r["seed"] < 10], 60, 30, peers)


def render_summary(datas: list) -> str:
    """README's results-summary line for paper 000 (the rows render_table2 shows)."""
    from app.jobs.recovery.reproduce.peers_check import summary_line

    rows, peers = datas
    rows = [r for r in _paper_budget(rows or []) if r["seed"] < 10]
    return summary_line(rows, peers, 30, 60, rows[0]["timestep_s"]) if rows else ""


def _seed0_bullets(fine: dict, coarse: dict) -> list[str]:
    dmg = [d for d in SCENARIOS if d in fine]
    met = [d for d in dmg if fine[d]["target_met"]]
    missed2 = [f"{page_prose.loss(d)} ({page_prose.misses(coarse[d]['best'])})" for d in dmg if d in coarse and not coarse[d]["target_met"]]
    cases = lambda rows: ", ".join(f"{r['robustness']['met']}" for r in rows)  # noqa: E731
    out = [f"- {len(met)} of {len(dmg)} damages meet the target on the nominal model at 1 ms"
           + (f"; at 2 ms {'; '.join(missed2)} missed it" if missed2 else "") + ". Under the "
           f"{fine[dmg[0]]['robustness']['total']} robustness cases (the step halved and quartered among them) the "
           f"answers keep it in {cases([fine[d] for d in dmg])} cases"
           + (f" (at 2 ms: {cases([coarse[d] for d in dmg if d in coarse])})" if coarse else "") + "."]
    steps = [d for d in dmg if all(fine[d]["robustness"]["cases"][c]["target_met"] for c in ("dt_half", "dt_quarter"))]
    broke = {c: [d for d in dmg if not fine[d]["robustness"]["cases"][c]["target_met"]]
             for c in fine[dmg[0]]["robustness"]["cases"]}
    worst = sorted((c for c in broke if broke[c]), key=lambda c: -len(broke[c]))[:2]
    first = fine[dmg[0]]["robustness"]["cases"]
    shown = [c for c in worst if dmg[0] in broke[c]]  # the first damage's figures where it misses the target
    out.append(f"- {len(steps)} of {len(dmg)} answers keep it at half and a quarter of the step; the cases that break "
               "most of them are " + " and ".join(f"{c} ({len(broke[c])} of {len(dmg)})" for c in worst)
               + (f" ({page_prose.loss(dmg[0])} there: " + "; ".join(f"{page_prose.misses(first[c])} at {c}" for c in shown) + ")"
                  if shown else "") + ".")
    rs = [d for d in dmg if fine[d]["random_search"]]
    rs_met = [d for d in rs if fine[d]["random_search"]["target_met"]]
    less = [d for d in rs if fine[d]["random_search"]["metrics"]["y_f_m"] < fine[d]["best"]["y_f_m"]]
    fwd = lambda ds, key: " / ".join(f"{100 * key(fine[d])['y_f_m']:.1f}" for d in ds)  # noqa: E731
    out.append(f"- The random search at the same budget meets the target in {len(rs_met)} of {len(rs)} damages"
               + (f" (not for {', '.join(page_prose.loss(d) for d in rs if d not in rs_met)})" if len(rs_met) < len(rs) else "")
               + f" and walks less far in {len(less)} of {len(rs)} ({fwd(rs, lambda r: r['random_search']['metrics'])} "
               f"cm against DE's {fwd(rs, lambda r: r['best'])}, in the order of Table II).")
    base = [page_prose.loss(d) for d in dmg if fine[d]["baseline_target_met"]]
    out.append(f"- The nominal tripod (no recovery) already meets the target with {', '.join(base)} lost."
               if base else "- The nominal tripod (no recovery) meets the target on none of them.")
    return out


def render_table2_seed0(datas: list) -> str:
    """docs/recovery.md's 'what seed 0 shows': Table II's seed-0 answers at 1 ms (beside the
    2 ms ones), their perturbations and the random-search control, from docs/table2.json."""
    rows = [r for r in _paper_budget(datas[0] or [], any_step=True) if r["seed"] == 0]
    fine = {tuple(r["lost_legs"]): r for r in rows if r["timestep_s"] == 0.001}
    coarse = {tuple(r["lost_legs"]): r for r in rows if r["timestep_s"] == 0.002}
    return "\n".join(_seed0_bullets(fine, coarse)) if fine else "*No seed-0 rows at 1 ms in docs/table2.json yet.*"


def table2_page(md: str) -> str:
    """The page `gaitmend reproduce recovery` writes: its table inside the generated-section
    marker, so `gaitmend docs` and the docs-from-data test re-render it from the JSON."""
    return (f"# Paper 000's Table II, simulated\n\n"
            f"{marked(TABLE2_SECTION, 'gaitmend reproduce recovery --write-docs', md)}\n")


def run_table2(seeds: int, generations: int, population: int, log: Callable[[str], None] = print,
               raw_path: Path | None = Path("docs/table2.json"), peers_path: Path | None = None,
               render_only: bool = False) -> str:
    """Runs what ``raw_path`` lacks (``render_only``: nothing; the page from the files as
    they are) and renders the page with the peers' ledger at ``peers_path``."""
    if render_only:
        rows = _paper_budget(json.loads(raw_path.read_text()) if raw_path and raw_path.exists() else [],
                             generations, population)
    else:
        rows = run_scenarios(seeds, generations, population, log, raw_path)
    rows = [r for r in rows if r["seed"] < seeds]
    peers = json.loads(peers_path.read_text()) if peers_path is not None and peers_path.exists() else None
    return table_markdown(rows, generations, population, peers)


# -- robust vs nominal recovery on every feasible 1- and 2-leg loss -----------------------------

ROBUST_MODELS = ["friction_0.7", "friction_1.3", "payload"]  # trained on; the other four cases are held out


def run_robust_comparison(generations: int, population: int, seed: int = 0, aggregate: str = "worst",
                          log: Callable[[str], None] = print, raw_path: Path | None = None,
                          scenarios: list[tuple[int, ...]] | None = None,
                          weights: list[float] | None = None) -> list[dict]:
    """For each damage: the nominal search and the robust search (nominal model plus
    ROBUST_MODELS, ``aggregate`` of Eq. 5), same DE budget in candidates, both answers
    re-simulated under all seven standard perturbations. Resumable like run_scenarios."""
    timestep = RecoverySpec().sim.timestep_s
    weights = list(weights or RecoverySpec().objective.weights)
    rows, others = _rows_in(raw_path, lambda r: r.get("generations") == generations
                            and r.get("population") == population and r.get("timestep_s") == timestep
                            and r.get("aggregate") == aggregate)
    done = {(tuple(r["lost_legs"]), r["mode"], tuple(r.get("weights", RecoverySpec().objective.weights)))
            for r in rows}
    for lost in scenarios or feasible_losses():
        for mode in ("nominal", "robust"):
            if (lost, mode, tuple(weights)) in done:
                continue
            d = {"damage": {"lost_legs": list(lost)},
                 "search": {"population": population, "generations": generations, "seed": seed},
                 "controls": {"random_search": False}, "objective": {"weights": weights}}
            if mode == "robust":
                d["robust"] = {"models": ROBUST_MODELS, "aggregate": aggregate}
            spec = RecoverySpec(**d)
            s, wall = _run_and_keep(spec, lambda s: {
                "lost_legs": list(lost), "mode": mode, "seed": seed, "generations": generations,
                "population": population, "timestep_s": s["timestep_s"], "aggregate": aggregate,
                "robust_models": ROBUST_MODELS if mode == "robust" else [], "weights": weights,
                "baseline": s["baseline"]["metrics"], "baseline_target_met": s["baseline"]["target_met"],
                "best": s["best"]["metrics"], "best_params": s["best"]["params"],
                "target_met": s["best"]["target_met"], "gait": s["gait"]["name"],
                "robustness": robustness_row(s, ("x_f_m", "y_f_m", "yaw_f_deg", "fell")),
                "evaluations": s["timing"]["evaluations"], "wall_s": s["timing"]["wall_s"]}, rows, others, raw_path)
            m, rob = s["best"]["metrics"], rows[-1]["robustness"]
            log(f"legs {lost} {mode} (weights {weights}): x {100 * m['x_f_m']:.1f} cm, y {100 * m['y_f_m']:.1f} cm, "
                f"yaw {m['yaw_f_deg']:.1f} deg, target {s['best']['target_met']}, perturbations met "
                f"{rob['met']}/{rob['total']} ({wall:.0f} s)")
    return rows


def robust_markdown(rows: list[dict]) -> str:
    """One line per damage: nominal vs robust answer, on the nominal model and under the
    seven perturbations (the three trained on and the four held out)."""
    if not rows:
        return ""
    r0 = rows[0]
    trained = r0["robust_models"] or ROBUST_MODELS
    cases = list(r0["robustness"]["cases"])
    held = [c for c in cases if c not in trained]
    out = [f"DE {r0['population']} x {r0['generations']} (reduced budget), seed {r0['seed']}, timestep "
           f"{1000 * r0['timestep_s']:g} ms, 10 s walks. Robust = each candidate scored on the nominal model and on "
           f"{', '.join(trained)} in one batched rollout, fitness = {r0['aggregate']} over the four. Perturbation "
           f"columns count the cases whose re-simulation meets the target; held out (never searched on): "
           f"{', '.join(held)}.", "",
           "| damage | baseline meets target | nominal answer x / y / yaw | nominal: target, perturbations met "
           "(held out) | robust answer x / y / yaw | robust: target, perturbations met (held out) | wall s nominal / robust |",
           "|---|---|---|---|---|---|---|"]
    by = {}
    for r in rows:
        by.setdefault(tuple(r["lost_legs"]), {})[r["mode"]] = r
    tot = {"nominal": [0, 0, 0], "robust": [0, 0, 0]}
    for lost, d in by.items():
        if set(d) != {"nominal", "robust"}:
            continue
        cells = []
        for mode in ("nominal", "robust"):
            r = d[mode]
            m = r["best"]
            held_met = sum(r["robustness"]["cases"][c]["target_met"] for c in held)
            cells += [f"{100 * m['x_f_m']:.1f} / {100 * m['y_f_m']:.1f} / {m['yaw_f_deg']:.1f}",
                      f"{'yes' if r['target_met'] else 'no'}, {r['robustness']['met']}/{r['robustness']['total']} "
                      f"({held_met}/{len(held)})"]
            tot[mode][0] += r["target_met"]
            tot[mode][1] += r["robustness"]["met"]
            tot[mode][2] += held_met
        out.append(f"| {_name(lost)} | {'**yes**' if d['nominal']['baseline_target_met'] else 'no'} | "
                   + " | ".join(cells) + f" | {d['nominal']['wall_s']:.0f} / {d['robust']['wall_s']:.0f} |")
    n = sum(1 for d in by.values() if set(d) == {"nominal", "robust"})
    out += ["", f"Over {n} damages: nominal search meets the target on the nominal model in {tot['nominal'][0]}, "
                f"and {tot['nominal'][1]}/{7 * n} perturbed re-runs ({tot['nominal'][2]}/{len(held) * n} held out); "
                f"robust search {tot['robust'][0]}, {tot['robust'][1]}/{7 * n} ({tot['robust'][2]}/{len(held) * n}).", ""]
    out += rejudge.rejudged_note(rows, lambda r: f"{_name(r['lost_legs'])}, {r['mode']} answer")
    return "\n".join(out)
ROBUST_W20_JSON = "docs/recovery_robust_w20.json"
ROBUST_W20_COMMAND = ("gaitmend reproduce recovery-robust --weights 1,20,10,100,100 --raw docs/recovery_robust_w20.json "
                      "--out docs/recovery_robust_w20.md")


ROBUST_JSON, ROBUST_COMMAND = "docs/recovery_robust.json", "gaitmend reproduce recovery-robust"


def render_robust(datas: list) -> str:
    """docs/recovery_robust.md: the comparison at the paper's weights (rows without weights
    predate them and were run at them), at the finest step the file holds (the 2 ms pilot
    until the command is run at a finer default step)."""
    if datas[0] is None:
        return missing(ROBUST_JSON, ROBUST_COMMAND)
    paper = list(RecoverySpec().objective.weights)
    rows = [r for r in datas[0] if r.get("weights", paper) == paper]
    return robust_markdown([r for r in rows if r["timestep_s"] == min(r["timestep_s"] for r in rows)])


def render_robust_w20(datas: list) -> str:
    """The drift-weighted robust comparison at the default step (the rows its command tables)."""
    if datas[0] is None:
        return missing(ROBUST_W20_JSON, ROBUST_W20_COMMAND)
    step = RecoverySpec().sim.timestep_s
    return robust_markdown([r for r in datas[0] if r["timestep_s"] == step])


# the robust comparisons the docs publish: their rows' file -> (section, its command, the page's title, renderer)
ROBUST_PAGES = {ROBUST_JSON: ("recovery-robust", ROBUST_COMMAND, "# Robust vs nominal recovery search", render_robust),
                ROBUST_W20_JSON: ("recovery-robust-w20", ROBUST_W20_COMMAND,
                                  "# Robust vs nominal recovery search, drift weighted", render_robust_w20)}


class Table2Params(BaseModel):
    seeds: int = Field(10, ge=1, le=100, description="seeds per scenario")
    generations: int = Field(60, ge=1, le=10000, description="DE generations (paper: 60)")
    population: int = Field(30, ge=4, le=1000, description="DE population (paper: 30)")
    out: Path = Field(Path("docs/table2.md"), description="markdown table to write")
    raw: Path = Field(Path("docs/table2.json"), description="per-run rows; runs already there are not run again")
    peers: Path = Field(Path("docs/table2_peers.json"), description="scipy DE and CMA-ES runs at the same budget "
                                                                     "(`gaitmend reproduce recovery-peers`), read only")
    render_only: bool = Field(False, description="run nothing: the page from the rows in --raw and --peers as they are")


def _table2(p: Table2Params, log: Callable[[str], None]) -> str:
    if p.render_only:
        md = run_table2(p.seeds, p.generations, p.population, log, p.raw, p.peers, render_only=True)
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(table2_page(md))
        return md
    runs = 4 * p.seeds
    scale = p.population * (p.generations + 1) / (30 * 61) * (0.001 / RecoverySpec().sim.timestep_s)
    done = json.loads(p.raw.read_text()) if p.raw.exists() else []
    log(f"{runs} runs (4 scenarios x {p.seeds} seeds); {jobtime.estimate(done, ROW_VERSION, runs, scale)}, "
        f"less for runs already in {p.raw}")
    md = run_table2(seeds=p.seeds, generations=p.generations, population=p.population, log=log, raw_path=p.raw,
                    peers_path=p.peers)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(table2_page(md))
    return md


class RobustParams(BaseModel):
    generations: int = Field(12, ge=1, le=10000, description="DE generations (reduced budget)")
    population: int = Field(12, ge=4, le=1000, description="DE population (reduced budget)")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="seed of both searches")
    aggregate: str = Field("worst", pattern="^(mean|worst)$", description="robust fitness: mean or worst over models")
    weights: str = Field("", pattern=r"^$|^[0-9.eE+-]+(,[0-9.eE+-]+){4}$",
                         description="Eq. 5 weights w1..w5 for both searches, comma-separated (default: the paper's)")
    out: Path = Field(Path("docs/recovery_robust.md"), description="markdown table to write")
    raw: Path = Field(Path("docs/recovery_robust.json"), description="per-run rows; runs already there are not run again")

    @field_validator("weights")
    @classmethod
    def _weights_within_the_specs_bounds(cls, v: str) -> str:
        if v:
            from app.jobs.base import SpecError

            try:
                RecoverySpec.parse({"objective": {"weights": [float(w) for w in v.split(",")]}})
            except SpecError as e:
                raise ValueError("; ".join(f"{x['field']}: {x['message']}" for x in e.errors)) from None
        return v


def _robust(p: RobustParams, log: Callable[[str], None]) -> str:
    weights = [float(w) for w in p.weights.split(",")] if p.weights else list(RecoverySpec().objective.weights)
    rows = run_robust_comparison(p.generations, p.population, p.seed, p.aggregate, log=log, raw_path=p.raw,
                                 weights=weights)
    rows = [r for r in rows if r.get("weights", weights) == weights]
    md = robust_markdown(rows)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(robust_page(p.raw, md))
    return md


def robust_page(raw: Path, md: str) -> str:
    """The page `reproduce recovery-robust` writes: for a file the docs publish, its title and
    its generated section as the section renders the file (`gaitmend docs` re-renders it;
    the data wins over the run's own rows); for any other file, the run's ``md``."""
    for path, (name, command, title, render) in ROBUST_PAGES.items():
        if raw.resolve() == Path(path).resolve():
            body = render([json.loads(raw.read_text())]).strip("\n")
            return f"{title}\n\n{marked(name, command, body)}\n"
    return md


EXPERIMENTS = [
    Experiment("table2", "Paper 000's Table II scenarios (legs 1&6, 3&4, 1, 4 lost) over seeds, with the "
                         "random-search control and the robustness block; writes the table", Table2Params, _table2,
               (Section(TABLE2_SECTION, (TABLE2_JSON, PEERS_JSON), render_table2),
                Section("recovery-table2-seed0", (TABLE2_JSON,), render_table2_seed0),
                Section("recovery-default-result", (TABLE2_JSON,),
                        lambda datas: page_prose.render_default_result(datas, ROW_VERSION)),
                Section("recovery-job-time", (TABLE2_JSON,), lambda datas: jobtime.render_job_time(datas, ROW_VERSION)),
                Section("recovery-f-scale", (TABLE2_JSON,), lambda datas: jobtime.render_f_scale(datas, ROW_VERSION)),
                Section("readme-first-command-time", (TABLE2_JSON, "docs/readme_examples.json"),
                        lambda datas: jobtime.render_readme_time(datas, ROW_VERSION)),
                Section("recovery-summary", (TABLE2_JSON, PEERS_JSON), render_summary, readme=True))),
    Experiment("peers", "issue 28: scipy's differential_evolution and CMA-ES at the paper DE's budget (30 x 61 walks "
                        "of 10 s at 1 ms) on the four Table II damages over seeds, each run appended to "
                        "docs/table2_peers.json; the Table II page pairs them with our DE",
               peers_check.PeersParams, peers_check.run_peers),
    Experiment("atlas", "issue 28: the damage atlas as data: every feasible 1- and 2-leg loss at the paper's budget "
                        "and the default step over seeds, each run appended to docs/recovery_atlas.json (Table II's "
                        "four damages: its own runs)", atlas_check.AtlasParams, atlas_check.run_atlas,
               (Section("recovery-atlas", (atlas_check.JSON, TABLE2_JSON), atlas_check.render),)),
    Experiment("robust", "robust vs nominal recovery on every feasible 1- and 2-leg loss, both answers re-run "
                         "under seven perturbations", RobustParams, _robust,
               tuple(Section(name, (path,), render) for path, (name, _, _, render) in ROBUST_PAGES.items())
               + (Section("recovery-robust-w20-verdict", (ROBUST_W20_JSON,), page_prose.render_robust_w20_verdict),
                  Section("recovery-robust-pilot", (ROBUST_JSON, ROBUST_W20_JSON), page_prose.render_robust_pilot))),
    Experiment("baselines", "the nominal tripod on every feasible loss and some partial damages: falls, "
                            "already meets the target?", BaselinesParams, _baselines,
               (Section("recovery-baselines", (BASELINES_JSON,), render_baselines),)),
    Experiment("convergence", "search at a timestep, re-simulate the answers at half of it: the convergence rule",
                ConvergenceParams, _convergence,
               (Section(CONVERGENCE_SECTIONS[0], (CONVERGENCE_JSON,), render_convergence_table),
                Section(CONVERGENCE_SECTIONS[1], (CONVERGENCE_JSON,), render_convergence_answers),
                Section("recovery-convergence-verdict", (CONVERGENCE_JSON, ROBUST_W20_JSON),
                        page_prose.render_convergence_verdict))),
    Experiment("speed", "issue 22: the step profile, the fast preset's time to the target, equal quality for less, "
                        "the paper DE with cut walks checked against Table II", SpeedParams, _speed,
               (Section("recovery-speed", ("docs/recovery_speed.json", TABLE2_JSON), render_speed),)),
    Experiment("closed-loop", "issue 24: the four Table II answers open and closed loop on the nominal model, the "
                              "7 named cases and held-out random models (evaluations, no search)",
               loop_check.LoopParams, loop_check.run_loop_check,
               (Section("recovery-closed-loop", (loop_check.JSON,), loop_check.render),)),
    Experiment("rejudge", "issue 47: the stored answers of Table II and the robust comparisons walked again under named "
                          "cases on today's worlds (no search): each row's case entries replaced and its count redone "
                          "(`gaitmend docs` then renders the pages)", rejudge.RejudgeParams, rejudge.run_rejudge),
    Experiment("randomised", "issue 24: randomised robust search against the nominal search at equal simulation "
                             "budget on the four Table II damages, answers judged on the same held-out random models",
               randomised_check.RandomisedParams, randomised_check.run_randomised,
               (Section("recovery-randomised", (randomised_check.JSON,), randomised_check.render),)),
    Experiment("choice", "issue 47: the robust choice against the same search's best F and a longer nominal search "
                         "at equal walks, closed loop, on the four Table II damages, answers judged on the same "
                         "held-out random models", choice_check.ChoiceParams, choice_check.run_choice,
               (Section("recovery-choice", (choice_check.JSON,), choice_check.render),)),
    Experiment("recommended", "issue 47's bar for the recommended mode (closed loop + robust choice): on Table II's "
                              "damages (answers from table2.json and recovery_choice.json) and random combined "
                              "damages (searched here), the paper's answer open and closed loop, the closed-loop "
                              "search's best F and the robust choice on the 7 named cases and the same held-out models",
               recommended_check.RecommendedParams, recommended_check.run_recommended,
               (Section("recovery-recommended", (recommended_check.JSON,), recommended_check.render),)),
]

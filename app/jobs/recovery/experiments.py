"""Paper 000's experiments and the recovery evidence: Table II in simulation (every row a
real run of this code), robust vs nominal recovery on every feasible 1- and 2-leg loss,
the baselines that need no recovery, and the timestep convergence study."""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field, field_validator

from app.core.host import machine
from app.jobs.base import Experiment, MemoryContext
from app.jobs.recovery import atlas_check, curves, jobtime, loop_check, peers_check, prose, randomised_check
from app.jobs.reporting import Section, marked, missing
from app.jobs.evidence import controls_of
from app.jobs.recovery.answers import answers_metrics, documented_answers
from app.jobs.recovery.rows import feasible_losses, robustness_row, search_row
from app.jobs.recovery.metrics import TARGET
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.speed import PARTS as SPEED_RUNS

SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]
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


def _save_rows(rows: list[dict], raw_path: Path | None) -> None:
    """Every finished run at once (a long reproduction resumes from it), never half-written."""
    if raw_path is None:
        return
    raw_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = raw_path.with_suffix(".part")
    tmp.write_text(json.dumps(rows, indent=1))
    tmp.replace(raw_path)


def _median(rows, key):
    return statistics.median(r["best"][key] for r in rows)


def _name(lost) -> str:
    return ("Legs " if len(lost) > 1 else "Leg ") + " & ".join(str(l) for l in lost) + " lost"


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
    from app.jobs.recovery.peers_check import comparisons_markdown

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
    from app.jobs.recovery.peers_check import summary_line

    rows, peers = datas
    rows = [r for r in _paper_budget(rows or []) if r["seed"] < 10]
    return summary_line(rows, peers, 30, 60, rows[0]["timestep_s"]) if rows else ""


def _seed0_bullets(fine: dict, coarse: dict) -> list[str]:
    dmg = [d for d in SCENARIOS if d in fine]
    met = [d for d in dmg if fine[d]["target_met"]]
    missed2 = [f"{prose.loss(d)} ({prose.misses(coarse[d]['best'])})" for d in dmg if d in coarse and not coarse[d]["target_met"]]
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
    out.append(f"- {len(steps)} of {len(dmg)} answers keep it at half and a quarter of the step; the cases that break "
               "most of them are " + " and ".join(f"{c} ({len(broke[c])} of {len(dmg)})" for c in worst)
               + f" ({prose.loss(dmg[0])} there: " + "; ".join(f"{prose.misses(first[c])} at {c}" for c in worst) + ").")
    rs = [d for d in dmg if fine[d]["random_search"]]
    rs_met = [d for d in rs if fine[d]["random_search"]["target_met"]]
    less = [d for d in rs if fine[d]["random_search"]["metrics"]["y_f_m"] < fine[d]["best"]["y_f_m"]]
    fwd = lambda ds, key: " / ".join(f"{100 * key(fine[d])['y_f_m']:.1f}" for d in ds)  # noqa: E731
    out.append(f"- The random search at the same budget meets the target in {len(rs_met)} of {len(rs)} damages"
               + (f" (not for {', '.join(prose.loss(d) for d in rs if d not in rs_met)})" if len(rs_met) < len(rs) else "")
               + f" and walks less far in {len(less)} of {len(rs)} ({fwd(rs, lambda r: r['random_search']['metrics'])} "
               f"cm against DE's {fwd(rs, lambda r: r['best'])}, in the order of Table II).")
    base = [prose.loss(d) for d in dmg if fine[d]["baseline_target_met"]]
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


# -- the convergence rule on a set of recovered answers -----------------------------------------

def convergence_report(answers: list[dict], timestep: float) -> dict:
    from app.jobs.recovery.convergence import check, halving_deltas

    a, b = answers_metrics(answers, timestep), answers_metrics(answers, timestep / 2)
    d = halving_deltas(a, b)
    return check(d) | {"timestep_s": timestep,
                       "per_answer": [{"lost_legs": ans["lost_legs"], "seed": ans.get("seed"),
                                       "best_params": ans["best_params"],
                                       "x_cm": [100 * float(a["x_f_m"][i]), 100 * float(b["x_f_m"][i])],
                                       "yaw_deg": [float(a["yaw_f_deg"][i]), float(b["yaw_f_deg"][i])],
                                       "y_cm": [100 * float(a["y_f_m"][i]), 100 * float(b["y_f_m"][i])]}
                                      for i, ans in enumerate(answers)]}


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
    return "\n".join(out)


# -- which damages need no recovery at all --------------------------------------------------------

PARTIAL_DAMAGES = [
    {"locked_joints": [{"leg": 2, "joint": "femur", "angle_deg": 20.0}]},
    {"locked_joints": [{"leg": 3, "joint": "femur", "angle_deg": -20.0}]},
    {"lost_legs": [4], "weak_joints": [{"leg": 3, "joint": "tibia", "torque_scale": 0.3}]},
    {"lost_legs": [1], "weak_joints": [{"leg": 2, "joint": "tibia", "torque_scale": 0.3}]},
]


BASELINES_JSON = "docs/recovery_baselines.json"
BASELINES_COMMAND = "gaitmend reproduce recovery-baselines --write-docs"
BASELINE_KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "tilt_max_deg", "under_3_feet_frac", "fell")


def baselines_data(log: Callable[[str], None] = print) -> dict:
    """The nominal tripod (no recovery) on every feasible 1- and 2-leg loss and a few
    partial damages: does it fall, does it already meet the target? One batch per damage;
    the JSON docs/recovery_baselines.json holds (the page is rendered from it)."""
    from app.jobs.recovery.sequences import nominal_tripod
    from app.jobs.recovery.run import functional_legs, nominal_params, sim_config, sim_model
    from app.robots.catalog import get_robot
    from app.jobs.recovery.evaluate import GaitEvaluator

    t0, c0 = time.monotonic(), time.process_time()
    spec0, rows = RecoverySpec(), []
    for dmg in [{"lost_legs": list(l)} for l in feasible_losses()] + PARTIAL_DAMAGES:
        spec = RecoverySpec(damage=dmg)
        robot = get_robot(spec.robot)
        _, model = sim_model(spec, robot)
        legs = functional_legs(spec)
        ev = GaitEvaluator(robot, model, nominal_tripod(legs), sim_config(spec))
        m = {k: v[0] for k, v in ev.evaluate(nominal_params(robot, legs)).metrics.items()}
        ev.close()
        rows.append({"damage": dmg, "text": _damage_text(dmg), "target_met": bool(TARGET.met(m)),
                     "metrics": {k: (bool(m[k]) if k == "fell" else float(m[k])) for k in BASELINE_KEEP}})
        log(json.dumps(rows[-1]))
    return {"command": BASELINES_COMMAND, "timestep_s": spec0.sim.timestep_s, "duration_s": spec0.sim.duration_s,
            "rows": rows, "wall_s": time.monotonic() - t0, "cpu_s": time.process_time() - c0}


def render_baselines(datas: list) -> str:
    d = datas[0]
    if d is None:
        return missing(BASELINES_JSON, BASELINES_COMMAND)
    out = [f"The nominal tripod with nominal parameters (no recovery) on each damage; timestep "
           f"{1000 * d['timestep_s']:g} ms, {d['duration_s']:g} s walk. 'fell': chassis, coxa or femur touched the "
           "ground. '< 3 feet': share of the walk with fewer than three feet on the ground.", "",
           "| damage | x (cm) | y (cm) | yaw (deg) | max tilt (deg) | < 3 feet | fell | meets the target |",
           "|---|---|---|---|---|---|---|---|"]
    for r in d["rows"]:
        m = r["metrics"]
        out.append(f"| {r['text']} | {100 * m['x_f_m']:.1f} | {100 * m['y_f_m']:.1f} | {m['yaw_f_deg']:.1f} | "
                   f"{m['tilt_max_deg']:.1f} | {100 * m['under_3_feet_frac']:.0f} % | {'**yes**' if m['fell'] else 'no'} | "
                   f"{'**yes**' if r['target_met'] else 'no'} |")
    return "\n".join(out) + "\n"


def _damage_text(d: dict) -> str:
    parts = []
    if d.get("lost_legs"):
        parts.append(_name(tuple(d["lost_legs"])))
    for j in d.get("locked_joints", []):
        parts.append(f"leg {j['leg']} {j['joint']} locked at {j['angle_deg']:g} deg")
    for j in d.get("weak_joints", []):
        parts.append(f"leg {j['leg']} {j['joint']} at {100 * j['torque_scale']:g} % torque")
    return ", ".join(parts)


CONVERGENCE_BUDGET = (16, 12)  # DE population x generations of the convergence searches


def convergence_study(timestep: float, seeds: int = 2, population: int = CONVERGENCE_BUDGET[0],
                      generations: int = CONVERGENCE_BUDGET[1], log: Callable[[str], None] = print) -> dict:
    """Searches the paper's four damages at ``timestep`` (small DE budget, no controls),
    then re-simulates every answer at half the step: the rule's verdict for that step."""
    answers = []
    for seed in range(seeds):
        for lost in SCENARIOS:
            spec = RecoverySpec(damage={"lost_legs": list(lost)}, sim={"timestep_s": timestep},
                                search={"population": population, "generations": generations, "seed": seed},
                                controls={"random_search": False}, robustness={"cases": []})
            s = run(spec, MemoryContext()).summary
            answers.append({"lost_legs": list(lost), "seed": seed, "best_params": s["best"]["params"]})
            log(f"{1000 * timestep:g} ms, legs {lost} seed {seed} searched")
    return convergence_report(answers, timestep) | {"set": "searched", "population": population,
                                                    "generations": generations}


# What each verdict's answers are (a verdict's "set"): the table's words, and the per-answer
# list's heading adds "at that step" and, for the searches, their budget.
SET_WORDS = {"searched": "searched at the step", "documented": "every answer the docs report",
             "paper_damages": "the docs' answers for Table II's four damages"}


def _and(items: list) -> str:
    items = [str(i) for i in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def which_text(r: dict) -> str:
    """The heading words of a verdict's answers; a search's budget as the verdict records it
    (the verdicts written before it was recorded: the command's, CONVERGENCE_BUDGET), its
    damages and seeds from its answers."""
    words = SET_WORDS.get(r.get("set"), "")
    if r.get("set") == "searched":
        pop, gens = r.get("population", CONVERGENCE_BUDGET[0]), r.get("generations", CONVERGENCE_BUDGET[1])
        seeds = sorted({a["seed"] for a in r["per_answer"]})
        losses = list(dict.fromkeys(tuple(a["lost_legs"]) for a in r["per_answer"]))
        damages = ("the four Table II damages" if sorted(losses) == sorted(SCENARIOS)
                   else _and([_name(l).lower() for l in losses]))
        return f"searched at that step (DE {pop} x {gens}, {damages}, seed{'s' * (len(seeds) > 1)} {_and(seeds)})"
    return f"{words} at that step" if words else ""


def convergence_table(reports: list[dict]) -> list[str]:
    """The rule and one row per (step, set of answers): the lines convergence_markdown starts with."""
    from app.jobs.recovery.convergence import RULE_TEXT

    out = [f"Rule: {RULE_TEXT}.", "",
           "| step | answers | forward: max change | drift: median / max change (cm) | yaw: median / max change (deg) "
           "| answers within drift and yaw bands | passes |", "|---|---|---|---|---|---|---|"]
    for r in reports:
        out.append(f"| {1000 * r['timestep_s']:g} ms -> {500 * r['timestep_s']:g} ms | {r['answers']} "
                   f"({SET_WORDS.get(r.get('set'), '')}) | "
                   f"{100 * r['max_forward_rel']:.1f} % | {100 * r['median_lateral_m']:.1f} / {100 * r['max_lateral_m']:.1f} | "
                   f"{r['median_yaw_deg']:.1f} / {r['max_yaw_deg']:.1f} | {100 * r['share_within']:.0f} % | "
                   f"{'yes' if r['passes'] else '**no**'} |")
    return out


CONVERGENCE_JSON = "docs/recovery_convergence.json"
CONVERGENCE_COMMAND = "gaitmend reproduce recovery-convergence --timesteps 0.004,0.002,0.001"
CONVERGENCE_SECTIONS = ("recovery-convergence", "recovery-convergence-answers")  # the table, the per-answer lists
ROBUST_W20_JSON = "docs/recovery_robust_w20.json"
ROBUST_W20_COMMAND = ("gaitmend reproduce recovery-robust --weights 1,20,10,100,100 --raw docs/recovery_robust_w20.json "
                      "--out docs/recovery_robust_w20.md")


def render_convergence_table(datas: list) -> str:
    if datas[0] is None:
        return missing(CONVERGENCE_JSON, CONVERGENCE_COMMAND)
    return "\n".join(convergence_table(datas[0])) + "\n"


def render_convergence_answers(datas: list) -> str:
    """docs/recovery_convergence.md's per-answer lists, from docs/recovery_convergence.json."""
    if datas[0] is None:
        return missing(CONVERGENCE_JSON, CONVERGENCE_COMMAND)
    return "\n".join(convergence_answers(datas[0]))


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


def convergence_markdown(reports: list[dict]) -> str:
    return "\n".join(convergence_table(reports) + [""] + convergence_answers(reports))


def convergence_page(reports: list[dict]) -> str:
    """docs/recovery_convergence.md as the command writes it: a title, then the table and the
    per-answer lists inside their generated-section markers (`gaitmend docs` re-renders them)."""
    out = "# Timestep convergence of the recovered answers\n"
    for name, render in zip(CONVERGENCE_SECTIONS, (render_convergence_table, render_convergence_answers)):
        out += f"\n{marked(name, CONVERGENCE_COMMAND, render([reports]))}\n"
    return out


def convergence_answers(reports: list[dict]) -> list[str]:
    """Per verdict, every answer's x, yaw and y at the step and at half of it."""
    out = []
    for r in reports:
        out.append(f"Per answer at {1000 * r['timestep_s']:g} ms, {which_text(r)} (x cm, yaw deg: at the step -> at half of it):")
        for a in r["per_answer"]:
            out.append(f"- {_name(tuple(a['lost_legs']))}, seed {a['seed']}: x {a['x_cm'][0]:.1f} -> {a['x_cm'][1]:.1f}, "
                       f"yaw {a['yaw_deg'][0]:.1f} -> {a['yaw_deg'][1]:.1f}, y {a['y_cm'][0]:.1f} -> {a['y_cm'][1]:.1f}")
        out.append("")
    return out


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


class BaselinesParams(BaseModel):
    out: Path = Field(Path("docs/recovery_baselines.md"), description="the page to write (its generated section)")
    raw: Path = Field(Path(BASELINES_JSON), description="every damage's walk, the data the page is rendered from")


def _baselines(p: BaselinesParams, log: Callable[[str], None]) -> str:
    data = baselines_data(log=log)
    for path in (p.out, p.raw):
        path.parent.mkdir(parents=True, exist_ok=True)
    p.raw.write_text(json.dumps(data, indent=1) + "\n")
    md = render_baselines([data]).strip("\n") + "\n"
    p.out.write_text(marked("recovery-baselines", BASELINES_COMMAND, md) + "\n")
    return md


class ConvergenceParams(BaseModel):
    timesteps: str = Field("0.004,0.002,0.001", description="steps to test, comma-separated seconds")
    seeds: int = Field(2, ge=1, le=20, description="seeds per scenario (small DE searches)")
    out: Path = Field(Path("docs/recovery_convergence.md"), description="markdown to write")
    raw: Path = Field(Path("docs/recovery_convergence.json"),
                      description="the verdicts with every answer's parameters; a step's earlier verdict is replaced")


SET_ORDER = {"searched": 0, "paper_damages": 1, "documented": 2}


def _convergence(p: ConvergenceParams, log: Callable[[str], None]) -> str:
    def merge(new: list[dict]) -> list[dict]:  # a (step, set) verdict replaces the earlier one
        old = json.loads(p.raw.read_text()) if p.raw.exists() else []
        keys = {(r["timestep_s"], r["set"]) for r in new}
        rows = sorted([r for r in old if (r["timestep_s"], r.get("set")) not in keys] + new,
                      key=lambda r: (-r["timestep_s"], SET_ORDER.get(r.get("set"), 3)))
        _save_rows(rows, p.raw)
        return rows

    reps = [convergence_study(float(t), seeds=p.seeds, log=log) for t in p.timesteps.split(",")]
    merge(reps)
    # The rule on everything the docs report at each step (Table II, the robust comparisons'
    # nominal answers and these searches), and on those for the paper's four damages: the
    # verdicts the docs and tests quote.
    more = []
    for r in reps:
        answers = documented_answers(r["timestep_s"], p.raw.parent)
        if len(answers) > r["answers"]:
            more.append(convergence_report(answers, r["timestep_s"]) | {"set": "documented"})
            paper = [a for a in answers if tuple(a["lost_legs"]) in SCENARIOS]
            more.append(convergence_report(paper, r["timestep_s"]) | {"set": "paper_damages"})
    reports = merge(more)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(convergence_page(reports))
    return convergence_markdown(reports)


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
    from app.jobs.recovery import speed

    damages = {"table2": SCENARIOS, "1-6": [(1, 6)], "3-4": [(3, 4)]}[p.damages]
    if "bench" in p.parts.split(","):
        from app.jobs.recovery.bench import bench_recovery

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
    from app.jobs.recovery import speed

    return speed.render(datas)


EXPERIMENTS = [
    Experiment("table2", "Paper 000's Table II scenarios (legs 1&6, 3&4, 1, 4 lost) over seeds, with the "
                         "random-search control and the robustness block; writes the table", Table2Params, _table2,
               (Section(TABLE2_SECTION, (TABLE2_JSON, PEERS_JSON), render_table2),
                Section("recovery-table2-seed0", (TABLE2_JSON,), render_table2_seed0),
                Section("recovery-default-result", (TABLE2_JSON,),
                        lambda datas: prose.render_default_result(datas, ROW_VERSION)),
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
               + (Section("recovery-robust-w20-verdict", (ROBUST_W20_JSON,), prose.render_robust_w20_verdict),
                  Section("recovery-robust-pilot", (ROBUST_JSON, ROBUST_W20_JSON), prose.render_robust_pilot))),
    Experiment("baselines", "the nominal tripod on every feasible loss and some partial damages: falls, "
                            "already meets the target?", BaselinesParams, _baselines,
               (Section("recovery-baselines", (BASELINES_JSON,), render_baselines),)),
    Experiment("convergence", "search at a timestep, re-simulate the answers at half of it: the convergence rule",
                ConvergenceParams, _convergence,
               (Section(CONVERGENCE_SECTIONS[0], (CONVERGENCE_JSON,), render_convergence_table),
                Section(CONVERGENCE_SECTIONS[1], (CONVERGENCE_JSON,), render_convergence_answers),
                Section("recovery-convergence-verdict", (CONVERGENCE_JSON, ROBUST_W20_JSON),
                        prose.render_convergence_verdict))),
    Experiment("speed", "issue 22: the step profile, the fast preset's time to the target, equal quality for less, "
                        "the paper DE with cut walks checked against Table II", SpeedParams, _speed,
               (Section("recovery-speed", ("docs/recovery_speed.json", TABLE2_JSON), render_speed),)),
    Experiment("closed-loop", "issue 24: the four Table II answers open and closed loop on the nominal model, the "
                              "7 named cases and held-out random models (evaluations, no search)",
               loop_check.LoopParams, loop_check.run_loop_check,
               (Section("recovery-closed-loop", (loop_check.JSON,), loop_check.render),)),
    Experiment("randomised", "issue 24: randomised robust search against the nominal search at equal simulation "
                             "budget on the four Table II damages, answers judged on the same held-out random models",
               randomised_check.RandomisedParams, randomised_check.run_randomised,
               (Section("recovery-randomised", (randomised_check.JSON,), randomised_check.render),)),
]

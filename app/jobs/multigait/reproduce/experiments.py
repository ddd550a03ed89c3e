"""Paper 001's Table I-IV experiments at a chosen budget, written as markdown.

    gaitmend reproduce multigait --particles 12 --generations 20 --distance --seed 0 --json s0.json
    gaitmend reproduce multigait --from-json s0.json,s1.json --particles 12 --generations 20 --out t.md

Table I: coverage-based gaits on Empty for each robot healthy and with its 1 and 2 stuck
modules (final best and first-generation best / mean). Table II: distance-based gaits.
Tables III-IV: the reuse experiment (goal 30 mu, K = 100) with the coverage- and
distance-based gaits of the healthy robots. Every run is a ``multigait`` job with the
paper's parameters except the PSO budget given here.
"""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs import stats
from app.jobs.base import BenchEntry, Experiment, MemoryContext
from app.jobs.multigait.reproduce import paper_rows, stairs
from app.jobs.multigait.reproduce.compare import METRICS
from app.jobs.reporting import Section, md_table, missing, num
from app.jobs.multigait.run import run
from app.jobs.multigait.spec import MultigaitSpec
from app.robots.modular import SHAPES


def one(robot: str, stuck: list[int], cost: str, particles: int, generations: int, seed: int, plans: int) -> dict:
    spec = MultigaitSpec.model_validate({
        "kind": "multigait", "robot": robot, "damage": {"stuck_modules": stuck}, "cost": cost, "map": "empty",
        "search": {"particles": particles, "generations": generations, "seed": seed},
        "reuse": {"plans": plans}})
    t = time.perf_counter()
    res = run(spec, MemoryContext())
    s = res.summary
    return {"robot": robot, "stuck": stuck, "cost": cost, "seed": seed, "result": s["result"], "reuse": s["reuse"],
            "composition": s["composition"], "per_gait": s["per_gait"], "timing": s["timing"],
            "history": [{k: r[k] for k in ("generation", "best", "mean", "generation_best")} for r in s["history"]],
            "wall_s": time.perf_counter() - t}


def _ms(vals) -> str:
    v = np.asarray(vals, dtype=float)
    return f"{v.mean():.1f}" if v.size == 1 else f"{v.mean():.1f} / {v.std():.1f}"


def markdown(rows: list[dict], particles: int, generations: int) -> str:
    seeds = sorted({r["seed"] for r in rows})
    out = [f"Budget: {particles} particles x {generations} generations (paper: 20 x 150), k = 3, "
           "tau = 30 s, K = 150 (coverage) / 100 (distance), PSO w = 0.1, phi1 = phi2 = 2, Empty map; "
           f"seeds {seeds}" + (" (cells: mean / std over seeds)" if len(seeds) > 1 else "") + ".\n"]
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["cost"], r["robot"], tuple(r["stuck"])), []).append(r)
    for cost, unit in (("coverage", "coverage % of cells"), ("distance", "distance (mu) to the goal 15 mu ahead")):
        sel = [(key, g) for key, g in groups.items() if key[0] == cost]
        if not sel:
            continue
        out.append(f"\n### {cost}-based cost: {unit}\n")
        out.append("| robot | stuck modules | final best | first generation: best | first generation: mean | wall per run (s) |")
        out.append("|---|---|---|---|---|---|")
        for (_, robot, stuck), g in sel:
            res = [r["result"] for r in g]
            out.append(f"| {robot} | {list(stuck) or '-'} | {_ms([x['final_best'] for x in res])} | "
                       f"{_ms([x['initial_best'] for x in res])} | {_ms([x['initial_mean'] for x in res])} | "
                       f"{np.mean([r['wall_s'] for r in g]):.0f} |")
    reuse = [r for r in rows if not r["stuck"] and r["reuse"]]
    if reuse:
        out.append("\n### Reuse (Sec. V-C): goal 30 mu away, K = 100, 20 plans per gait set: "
                   "distance to goal (mu) and coverage (%), mean (std) over plans\n")
        out.append("| robot | gaits | seed | 1: Empty, same | 2: Column, same | 3: Column, opposite |")
        out.append("|---|---|---|---|---|---|")
        for r in reuse:
            cells = []
            for sc in ("empty_same", "column_same", "column_opposite"):
                v = r["reuse"][sc]
                cells.append(f"{v['distance_mu']['mean']:.1f} ({v['distance_mu']['std']:.1f}) / "
                             f"{v['coverage_pct']['mean']:.1f} ({v['coverage_pct']['std']:.1f})")
            out.append(f"| {r['robot']} | {r['cost']} | {r['seed']} | " + " | ".join(cells) + " |")
    comp = [r for r in rows if r["composition"]]
    if comp:
        out.append("\n### Composition error: the first 60 nodes of the best tree replayed in full simulation\n")
        out.append("| robot | stuck | cost | seed | mean edge (mu) | depth-1 error (mu) | position error mean / max (mu) | "
                   "error per edge / edge length | heading error mean (deg) |")
        out.append("|---|---|---|---|---|---|---|---|---|")
        for r in comp:
            c = r["composition"]
            out.append(f"| {r['robot']} | {r['stuck'] or '-'} | {r['cost']} | {r['seed']} | {c['mean_edge_length_mu']:.2f} | "
                       f"{c['depth1_position_error_mu']:.0e} | {c['position_error_mu']['mean']:.2f} / "
                       f"{c['position_error_mu']['max']:.2f} | {c['relative_error_per_edge']:.2f} | "
                       f"{c['heading_error_deg']['mean']:.1f} |")
    return "\n".join(out) + "\n"


class TablesParams(BaseModel):
    robots: str = Field("lizard,quadropod", description="comma-separated modular robots")
    particles: int = Field(20, ge=2, le=1000, description="PSO particles (paper: 20)")
    generations: int = Field(150, ge=1, le=10000, description="PSO generations (paper: 150)")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="search seed")
    plans: int = Field(20, ge=1, le=500, description="reuse plans per scenario (paper: 20)")
    distance: bool = Field(False, description="also distance-based runs of the healthy robots")
    out: Path = Field(Path("docs/multigait_tables.md"), description="markdown to write")
    json_out: Path | None = Field(None, description="also write the rows as JSON here")
    from_json: str | None = Field(None, description="comma-separated JSON files of earlier runs: only write the "
                                                    "markdown from their rows")


def tables(p: TablesParams, log: Callable[[str], None]) -> str:
    if p.from_json:
        rows = [r for f in p.from_json.split(",") for r in json.loads(Path(f).read_text())]
        return _write(p, rows, write_json=False)
    rows: list[dict] = []
    md = ""
    for robot in p.robots.split(","):
        f1, f2 = SHAPES[robot].failures
        runs = [(stuck, "coverage") for stuck in ([], [f1], [f1, f2])] + ([([], "distance")] if p.distance else [])
        for stuck, cost in runs:
            rows.append(one(robot, stuck, cost, p.particles, p.generations, p.seed, p.plans))
            log(json.dumps({k: rows[-1][k] for k in ("robot", "stuck", "cost", "result", "wall_s")}))
            md = _write(p, rows)
    return md


def _write(p: TablesParams, rows: list[dict], write_json: bool = True) -> str:
    md = markdown(rows, p.particles, p.generations)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(md)
    if p.json_out and write_json:
        from app.jobs.base import dumps

        p.json_out.write_text(dumps(rows))
    return md


# -- issue 28: the sections rendered from committed JSON ----------------------------------------

PAPER_JSON = ("docs/multigait_paper_s0.json", "docs/multigait_paper_s1.json")
COMPARE_JSON = "docs/multigait_compare.json"
COMPARE_FULL_JSON = "docs/multigait_compare_full.json"
COMPARE_FULL_COMMAND = ("gaitmend reproduce multigait-compare --particles 20 --generations 150 --arms random,paper "
                        "--seeds 0,1,2,3,4,5 --json-out docs/multigait_compare_full.json")
RUGGEDNESS_JSON = "docs/multigait_ruggedness.json"
PAPER_COMMAND = "gaitmend reproduce multigait --particles 20 --generations 150 --seed S --json-out docs/multigait_paper_sS.json"
WINDOW = 10  # generations at each end of a run whose swarm means are compared


def _paper_rows(datas: list) -> list[dict]:
    return [r for d in datas if d for r in d]


def render_paper_budget(datas: list) -> str:
    """Table I at the paper's budget (20 x 150), two seeds (the committed runs)."""
    rows = _paper_rows(datas)
    if not rows:
        return missing(PAPER_JSON[0], PAPER_COMMAND)
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["robot"], tuple(r["stuck"])), []).append(r)
    seeds = sorted({r["seed"] for r in rows})
    tab = []
    for (robot, stuck), g in groups.items():
        g = sorted(g, key=lambda r: r["seed"])
        best = [r["result"]["final_best"] for r in g]
        gen = [next((h["generation"] for h in r["history"] if h["best"] >= r["result"]["final_best"] - 1e-12), "-")
               for r in g]
        tab.append([robot.capitalize(), list(stuck) or "-", *[f"{b:.1f}" for b in best],
                    f"**{np.mean(best):.1f} / {np.std(best):.1f}**",
                    f"{np.mean([r['result']['initial_best'] for r in g]):.1f}",
                    f"{np.mean([r['result']['initial_mean'] for r in g]):.1f}", ", ".join(map(str, gen)),
                    f"{np.mean([r['wall_s'] for r in g]):.0f}"])
    return md_table(["robot", "stuck modules", *[f"seed {s}" for s in seeds], "final best, mean / std",
                     "first gen.: best", "first gen.: mean", "generation of the final best", "wall per run (s)"], tab)


def render_mean_claim(datas: list) -> str:
    """Does the swarm's generation mean rise? The mean of the last WINDOW generations
    against the first WINDOW, run by run, paired."""
    rows = _paper_rows(datas)
    if not rows:
        return missing(PAPER_JSON[0], PAPER_COMMAND)
    first = [float(np.mean([h["mean"] for h in r["history"][:WINDOW]])) for r in rows]
    last = [float(np.mean([h["mean"] for h in r["history"][-WINDOW:]])) for r in rows]
    up = sum(b > a for a, b in zip(first, last))
    res = stats.paired(last, first, names=(f"the last {WINDOW} generations", f"the first {WINDOW}"))
    return (f"In the {len(rows)} committed paper-budget runs (20 x 150, seeds 0 and 1, six rows each) the swarm's mean "
            f"coverage over the last {WINDOW} generations exceeds that over the first {WINDOW} in {up} of {len(rows)} "
            f"runs ({np.mean(first):.2f} % -> {np.mean(last):.2f} % on average). Last minus first: "
            + stats.paired_text(res, "points") + ". " + _mean_claim(res, rows, float(np.mean(first))) + "\n")


def _mean_claim(res: dict, rows: list[dict], first: float) -> str:
    """What the paired verdict lets the page say of the generation mean: a rise or a fall
    only when it is shown, else that neither is."""
    if res["shown"] is None:
        return ("So a change of the generation mean is **not shown** either way: these runs neither show that the "
                "swarm's population drifts toward better gait sets nor that it does not.")
    by = f"by about {abs(res['mean_diff']):.1f} points on a first-generation mean of {first:.1f} %"
    if res["shown"] == "control":
        return f"So the generation mean **falls**, {by}: the swarm's population drifts toward worse gait sets."
    ratio = float(np.mean([r["result"]["final_best"] for r in rows])) / first
    return (f"So the generation mean **does rise**, {by}: the swarm's population drifts toward better gait sets, "
            f"a small effect next to the best's {ratio:.0f}x.")


def render_composition(datas: list) -> str:
    """The composition error of the paper-budget runs' best trees (seed 0)."""
    rows = [r for r in (datas[0] or []) if r.get("composition")]
    if not rows:
        return missing(PAPER_JSON[0], PAPER_COMMAND)
    tab = [[r["robot"].capitalize(), r["stuck"] or "-", r["cost"], f"{c['mean_edge_length_mu']:.2f}",
            f"{c['depth1_position_error_mu']:.0e}", f"{c['position_error_mu']['mean']:.2f} / {c['position_error_mu']['max']:.2f}",
            f"{c['relative_error_per_edge']:.2f}", f"{c['heading_error_deg']['mean']:.1f}"]
           for r in rows for c in [r["composition"]]]
    rel = [r["composition"]["relative_error_per_edge"] for r in rows]
    return (md_table(["robot", "stuck", "cost", "mean edge (mu)", "depth-1 error (mu)", "position error mean / max (mu)",
                      "error per edge / edge length", "heading error mean (deg)"], tab)
            + f"\nA gait composed at the root is exact (depth-1 column: floating-point level); each further gait adds "
              f"{100 * min(rel):.0f}-{100 * max(rel):.0f} % of its length.\n")


def render_ruggedness(datas: list) -> str:
    """How much structure a search could follow: the same gait sets re-planned, and perturbed."""
    d = datas[0]
    if d is None:
        return missing(RUGGEDNESS_JSON, "gaitmend reproduce multigait-ruggedness --write-docs")
    pl = d["planner"]
    rows = [[f"planned again on {pl['streams']} other planner-draw streams (mean)", num(pl["corr"], "{:.3f}"),
             f"{num(pl['std_within_set'])} (spread within a set)", "-", "-"]]
    rows += [[f"gait parameters perturbed by {100 * q['eps']:g} % of the box width, simulated again",
              num(q["corr"]), num(q["mean_abs_change"]), num(q["gait_distance_corr"]),
              num(q["gait_distance_rel_change_median"])] for q in d["perturbed"]]
    return (f"{d['n']} uniform random gait sets of the healthy {d['robot'].capitalize()} (seed {d['seed']}, "
            f"coverage cost, K = {d['iterations']}, {d['gait_s']:g} s gaits): mean coverage {num(d['mean'])} %, "
            f"spread between sets {num(d['std_between_sets'])} points. Correlation of each set's coverage with "
            f"the original's:\n\n"
            + md_table(["the same gait sets", "coverage correlation", "mean coverage change (points)",
                        f"correlation of each gait's {d['gait_s']:g} s displacement",
                        "median relative change of that displacement"], rows)
            + f"\nOne run, {num(d.get('cpu_s'), '{:.0f}')} s of CPU.\n")


def _arm_vals(rows: list[dict], arm: str, key: str) -> dict[int, float]:
    return {r["seed"]: r[key] for r in rows if r["arm"] == arm}


POWER_HEADERS = ["metric", "difference [95 % interval], effect size, test: verdict",
                 "smallest true difference these seeds find with 80 % power, paired t-test alone (pts)",
                 "seeds needed for the observed difference at 80 % power (paired t-test, and at least "
                 f"{stats.fewest_pairs()}: the signed-rank test cannot reject with fewer)"]


def _paired_row(rows: list[dict], arm: str, key: str, label: str) -> tuple[int, list[str]] | None:
    """``arm`` against random search on ``key`` over the seeds both ran (None below two): the
    pair count and the POWER_HEADERS cells (the difference with its interval and verdict,
    the difference these seeds find with 80 % power, the seeds the observed one needs)."""
    a, b = _arm_vals(rows, arm, key), _arm_vals(rows, "random", key)
    seeds = sorted(set(a) & set(b))
    if len(seeds) < 2:
        return None
    res = stats.paired([a[s] for s in seeds], [b[s] for s in seeds], names=(arm, "random search"))
    need = stats.pairs_needed(res["mean_diff"], res["sd_diff"], most=1000)
    return len(seeds), [label.split(" (")[0].split(",")[0], stats.paired_text(res, "pts", 2),
                        num(stats.detectable(res["sd_diff"], res["n"]), "{:.1f}"),
                        "more than 1000" if need is None else str(need)]


def _per_evaluation(rows: list[dict]) -> list[float]:
    """Each run's wall time per evaluation (s)."""
    return [float(r["wall_s"]) / int(r["evaluations"]) for r in rows if r.get("wall_s") and r.get("evaluations")]


def render_compare_stats(datas: list) -> str:
    """PSO against random search, paired by seed, with the power the five seeds buy."""
    rows = datas[0]
    if not rows:
        return missing(COMPARE_JSON, "gaitmend reproduce multigait-compare --json-out docs/multigait_compare.json")
    p0 = rows[0]
    out = [f"Paired by seed (each seed's arms plan on the same draws), {p0['particles']} x {p0['generations']} = "
           f"{p0['evaluations']} evaluations per arm and seed (the paper's budget: 3000):\n"]
    tab, fewest = [], stats.fewest_pairs()
    for arm in ("paper", "constriction"):
        for key, label in METRICS:
            row = _paired_row(rows, arm, key, label)
            if row is None:
                continue
            n, cells = row
            fewest = min(fewest, n)
            tab.append([f"{arm} vs random", *cells])
    out.append(md_table(["comparison", *POWER_HEADERS], tab))
    out += ["", stats.PAIRED_NOTE + " \"Does not beat\" is therefore not a finding: "
            + ("at this budget and seed count, a true advantage of PSO smaller than the power column is not excluded."
               if fewest >= stats.fewest_pairs() else
               f"at this budget and {fewest} seeds no true advantage of PSO is excluded, however large; the power "
               "column says what the t-test alone could find with them.")]
    full = datas[1] if len(datas) > 1 else None
    return "\n".join(out) + "\n" + (_full_budget_measured(rows, full) if full else _full_budget_estimate(rows))


def _full_budget_measured(rows: list[dict], full: list[dict]) -> str:
    """Once runs at the paper's budget exist: their measured cost beside what these runs'
    wall time would have predicted for them."""
    per = statistics.median(_per_evaluation(rows))
    walls = [float(r["wall_s"]) for r in full if r.get("wall_s")]
    return (f"\nAt the paper's full budget ({FULL_BUDGET} evaluations an arm) the comparison is run below: "
            f"{len(walls)} arm-runs took {_minutes(walls)} each (wall), where these runs' wall time (median "
            f"{per:.2f} s an evaluation, their robustness blocks and a loaded machine included) predicted about "
            f"{per * FULL_BUDGET / 60:.0f} min.\n")


FULL_BUDGET = 20 * 150  # the paper's PSO: 20 particles x 150 generations, evaluations an arm


def _full_budget_estimate(rows: list[dict]) -> str:
    """What the comparison at the paper's full budget would cost, scaled by evaluations from
    these runs' own wall time (each run's robustness block included: an estimate on the high side)."""
    per = _per_evaluation(rows)
    if not per:
        return ""
    each = statistics.median(per) * FULL_BUDGET
    arms, seeds = 2, max(len({r["seed"] for r in rows}), stats.fewest_pairs())
    return (f"\nAt the paper's full budget ({FULL_BUDGET} evaluations an arm), one arm's run would take about "
            f"{each / 60:.0f} min here and {arms} arms x {seeds} seeds about {arms * seeds * each / 3600:.0f} h, "
            f"scaled by evaluations from these {len(per)} runs' wall time (median {statistics.median(per):.2f} s an "
            "evaluation at the load they ran at, each run's robustness block included: an estimate on the high "
            "side).\n")


def _minutes(walls: list[float]) -> str:
    lo, hi = f"{min(walls) / 60:.0f}", f"{max(walls) / 60:.0f}"
    return f"{lo} min" if lo == hi else f"{lo}-{hi} min"


def render_compare_full(datas: list) -> str:
    """PSO (the paper's coefficients) against random search at the paper's full budget: the
    runs there are, paired by seed once two seeds have both arms, and what is left to run."""
    from app.jobs.multigait.reproduce.compare import report

    rows = datas[0]
    if not rows:
        return missing(COMPARE_FULL_JSON, COMPARE_FULL_COMMAND)
    want = stats.fewest_pairs()
    paired = sorted({r["seed"] for r in rows if r["arm"] == "paper"} & {r["seed"] for r in rows if r["arm"] == "random"})
    out = [report(rows)]
    tab = [row[1] for row in (_paired_row(rows, "paper", key, label) for key, label in METRICS) if row]
    if tab:
        out.append("Paired by seed (PSO with the paper's coefficients minus random search):\n\n"
                   + md_table(POWER_HEADERS, tab) + "\n" + stats.PAIRED_NOTE + "\n")
    walls = [float(r["wall_s"]) for r in rows if r.get("wall_s")]
    versions = sorted({r.get("code_version") or "not recorded" for r in rows})
    left = max(want - len(paired), 0)
    out.append(f"{len(paired)} of the {want} seeds the signed-rank test needs to show a difference have both arms "
               f"at this budget"
               + ("; with fewer, no difference can be shown either way" if left else "")
               + f". Each arm-run took {_minutes(walls)} here (wall, {len(walls)} runs; "
               + f"code {', '.join(versions)}: `code_version` of compare.SCIENCE)"
               + (f", so the {left} seeds left need about {2 * left * statistics.median(walls) / 3600:.1f} h of "
                  f"one core; `{COMPARE_FULL_COMMAND}` continues them (runs in the file are kept)" if left else "")
               + ".\n")
    return "\n".join(out)


def render_compare(datas: list) -> str:
    from app.jobs.multigait.reproduce.compare import report, robustness_report

    rows = datas[0]
    if not rows:
        return missing(COMPARE_JSON, "gaitmend reproduce multigait-compare --json-out docs/multigait_compare.json")
    md = report(rows)
    rob = [{"arm": r["arm"], "seed": r["seed"], "nominal": r["in_sample_best"], "cases": r["robustness"]}
           for r in rows if "robustness" in r]
    if rob:
        md += ("\nEach run's best re-simulated (robustness cases of the job), coverage % planned on the search's "
               "draws:\n\n" + robustness_report(rob))
    return md


def render_summary(datas: list) -> str:
    """README's line: PSO against random search on held-out coverage, at each budget with two
    or more paired seeds (the paper's full budget, docs/multigait_compare_full.json, first)."""
    parts = []
    for rows in (datas[1] if len(datas) > 1 else None, datas[0]):
        if not rows:
            continue
        a, b = _arm_vals(rows, "paper", "heldout_mean"), _arm_vals(rows, "random", "heldout_mean")
        s = sorted(set(a) & set(b))
        if len(s) < 2:
            continue
        res = stats.paired([a[k] for k in s], [b[k] for k in s], names=("PSO", "random search"))
        parts.append(f"{rows[0]['evaluations']} evaluations, {res['n']} seeds: {res['mean_diff']:+.1f} points, "
                     f"{res['verdict']}")
    if not parts:
        return ""
    return (f"- **multigait** (paper 001): PSO against random search at equal budget, held-out coverage: "
            f"{'; '.join(parts)} ([docs/multigait.md](docs/multigait.md)).\n")


def _compare(p, log):
    from app.jobs.multigait.reproduce.compare import compare

    return compare(p, log)


def _compare_params():
    from app.jobs.multigait.reproduce.compare import CompareParams

    return CompareParams


def _ruggedness(p, log):
    from app.jobs.multigait.reproduce.compare import ruggedness_experiment

    return ruggedness_experiment(p, log)


def _ruggedness_params():
    from app.jobs.multigait.reproduce.compare import RuggednessParams

    return RuggednessParams


EXPERIMENTS = [Experiment("tables", "Paper 001's Tables I-IV (coverage and distance gaits, stuck modules, reuse) "
                                    "at a chosen PSO budget", TablesParams, tables,
                          (Section("multigait-paper-budget", PAPER_JSON, render_paper_budget),
                           Section("multigait-composition", PAPER_JSON[:1], render_composition),
                           Section("multigait-mean", PAPER_JSON, render_mean_claim))),
               Experiment("compare", "PSO (paper and constriction coefficients) against random search at equal "
                                     "budget over seeds, with held-out re-scoring and a Mann-Whitney U test",
                          _compare_params(), _compare,
                          (Section("multigait-compare", (COMPARE_JSON,), render_compare),
                           Section("multigait-compare-stats", (COMPARE_JSON, COMPARE_FULL_JSON), render_compare_stats),
                           Section("multigait-compare-full", (COMPARE_FULL_JSON,), render_compare_full),
                           Section("multigait-summary", (COMPARE_JSON, COMPARE_FULL_JSON), render_summary,
                                   readme=True))),
               Experiment("ruggedness", "How much of a random gait set's coverage a search could follow: re-plans "
                                        "on other planner draws, re-simulations of slightly perturbed gaits",
                          _ruggedness_params(), _ruggedness,
                          (Section("multigait-ruggedness", (RUGGEDNESS_JSON,), render_ruggedness),)),
               Experiment("rows", "The rows of Tables I-IV the paper has (five robots; Empty, Column; coverage and "
                                  "distance) at a stated fraction of its budget (resumable)", paper_rows.RowsParams,
                          paper_rows.rows, (Section("multigait-rows", (paper_rows.ROWS_JSON,), paper_rows.render_rows),
                                            Section("multigait-reuse", (paper_rows.ROWS_JSON,), paper_rows.render_reuse),
                                            Section("multigait-not-attempted", (paper_rows.ROWS_JSON,),
                                                    paper_rows.render_not_attempted))),
               Experiment("cells", "The coverage scale: the committed PSO-vs-random bests re-planned and counted at "
                                   "several cell sizes, against the node ceiling", paper_rows.CellsParams, paper_rows.cells,
                          (Section("multigait-cells", (paper_rows.CELLS_JSON,), paper_rows.render_cells),)),
               Experiment("stairs", "The staircase at a small budget (every expansion simulated): the trees' heights, "
                                    "the distance to the goal, the measured cost and the paper-size estimate from it",
                          stairs.StairsParams, stairs.stairs,
                          (Section("multigait-stairs", (stairs.STAIRS_JSON,), stairs.render_stairs),))]


def _bench(quick: bool, log: Callable[[str], None]) -> dict:
    from app.jobs.multigait.reproduce.bench import bench_multigait

    return bench_multigait(quick=quick)


BENCH = [BenchEntry("multigait", "one paper-size generation and one RRT-MP cost evaluation", _bench)]

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
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.base import BenchEntry, Experiment, MemoryContext
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


def _compare(p, log):
    from app.jobs.multigait.compare import compare

    return compare(p, log)


def _compare_params():
    from app.jobs.multigait.compare import CompareParams

    return CompareParams


def _ruggedness(p, log):
    from app.jobs.multigait.compare import ruggedness_experiment

    return ruggedness_experiment(p, log)


def _ruggedness_params():
    from app.jobs.multigait.compare import RuggednessParams

    return RuggednessParams


EXPERIMENTS = [Experiment("tables", "Paper 001's Tables I-IV (coverage and distance gaits, stuck modules, reuse) "
                                    "at a chosen PSO budget", TablesParams, tables),
               Experiment("compare", "PSO (paper and constriction coefficients) against random search at equal "
                                     "budget over seeds, with held-out re-scoring and a Mann-Whitney U test",
                          _compare_params(), _compare),
               Experiment("ruggedness", "How much of a random gait set's coverage a search could follow: re-plans "
                                        "on other planner draws, re-simulations of slightly perturbed gaits",
                          _ruggedness_params(), _ruggedness)]


def _bench(quick: bool, log: Callable[[str], None]) -> dict:
    from app.jobs.multigait.bench import bench_multigait

    return bench_multigait(quick=quick)


BENCH = [BenchEntry("multigait", "one paper-size generation and one RRT-MP cost evaluation", _bench)]

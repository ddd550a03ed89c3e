"""PSO against random search at equal budget on paper 001's coverage problem, over seeds.

    gaitmend reproduce multigait-compare --seeds 0,1,2,3,4 --particles 20 --generations 20 \
        --arms constriction,random,paper --json-out compare.json --out docs/multigait_compare.md

Every arm scores its candidates with the same evaluator (the gait sets simulated once,
RRT-MP with the search's planner draws, stream 0 of the run's seed) and spends the same
number of evaluations. Each arm's final best is then planned again with fresh planner
draws held out from the selection, and simulated with the timestep halved. The test:
one-sided Mann-Whitney U (scipy) of PSO's against random search's values over the seeds.
Runs already in the JSON file are not run again (a long comparison can be resumed).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.optim.pso import PRESETS, ParticleSwarm
from app.optim.random_search import RandomSearch
from app.planning.costs import evaluate
from app.planning.evidence import CASES, gait_metrics, heldout_values
from app.planning.maps import get_map
from app.planning.primitives import ModularSim
from app.robots.modular import get_shape


def make(arm: str, lower, upper, particles: int, seed: int):
    if arm == "random":
        return RandomSearch(lower, upper, particles, seed=seed + 7919)
    return ParticleSwarm(lower, upper, particles, seed=seed, **PRESETS[arm])


def one(arm: str, robot: str, seed: int, particles: int, generations: int, heldout: int,
        log: Callable[[str], None] = print, gait_s: float = 30.0, settle_s: float = 1.0, iterations: int = 150) -> dict:
    """One arm on one seed: the paper's coverage problem (k = 3, tau = 30 s, K = 150, Empty)
    unless ``gait_s`` / ``iterations`` make it cheaper (tests)."""
    shape = get_shape(robot)
    pmap = get_map("empty")
    pmap = pmap.with_start_goal(pmap.start, (pmap.start[0] + 15.0, pmap.start[1], 0.5))
    k, K, radius = 3, iterations, shape.radius_mu()
    sim = ModularSim(shape, (), pmap, gait_s, settle_s)
    t0 = time.perf_counter()
    try:
        lo, hi = sim.bounds(k)
        opt = make(arm, lo, hi, particles, seed)
        rows = []
        for g in range(generations):
            x = opt.ask()
            ev = evaluate(sim, x, k, pmap, K, "coverage", seed, radius)
            opt.tell(ev.fitness)
            d = opt.diagnostics() if hasattr(opt, "diagnostics") else {}
            rows.append({"generation": g + 1, "evaluations": (g + 1) * particles, "best": opt.best[1],
                         "mean": float(ev.value.mean()), **d})
            log(f"{arm} seed {seed} gen {g + 1}: best {opt.best[1]:.2f} mean {ev.value.mean():.2f} {d}")
        bx, bf = opt.best
        held = heldout_values(sim, bx, k, pmap, K, "coverage", seed, radius, heldout)
    finally:
        sim.close()
    case = CASES[0]  # dt_half
    sim2 = ModularSim(shape, (), pmap, gait_s, settle_s, physics=case.physics())
    try:
        dth = gait_metrics(sim2, bx, k, pmap, K, "coverage", seed, radius)
    finally:
        sim2.close()
    return {"arm": arm, "robot": robot, "seed": seed, "particles": particles, "generations": generations,
            "evaluations": particles * generations, "in_sample_best": bf,
            "heldout_mean": float(held.mean()), "heldout_std": float(held.std()),
            "dt_half_coverage": dth["coverage_pct"], "history": rows, "best_x": bx.tolist(),
            "gait_s": gait_s, "iterations": K, "wall_s": time.perf_counter() - t0}


METRICS = (("in_sample_best", "best coverage % on the search's own planner draws (in-sample)"),
           ("heldout_mean", "the same gait set planned again on 20 fresh planner draws (held out), mean"),
           ("dt_half_coverage", "the same gait set re-simulated at half the timestep, planned on the search's draws"))


def mann_whitney(a, b) -> dict:
    """One-sided Mann-Whitney U: are the values of ``a`` larger than those of ``b``?"""
    from scipy.stats import mannwhitneyu

    r = mannwhitneyu(a, b, alternative="greater")
    return {"U": float(r.statistic), "p": float(r.pvalue), "n": [len(a), len(b)]}


def report(rows: list[dict]) -> str:
    arms = [a for a in ("constriction", "paper", "random") if any(r["arm"] == a for r in rows)]
    seeds = sorted({r["seed"] for r in rows})
    by = {(r["arm"], r["seed"]): r for r in rows}
    p0 = rows[0]
    out = [f"{p0['robot']}, healthy, coverage cost, Empty map, k = 3, tau = {p0.get('gait_s', 30.0):g} s, "
           f"K = {p0.get('iterations', 150)}; "
           f"{p0['particles']} particles x {p0['generations']} generations = {p0['evaluations']} evaluations per arm "
           f"and seed; seeds {seeds}.\n"]
    out.append("| arm | seed | in-sample best | held-out mean (std) | dt/2 | first-gen. mean | last-gen. mean | "
               "last-gen. share of coordinates on a wall | last-gen. spread |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for a in arms:
        for s in seeds:
            r = by.get((a, s))
            if r is None:
                continue
            h0, h1 = r["history"][0], r["history"][-1]
            wall = f"{h1['at_bounds']:.3f}" if "at_bounds" in h1 else "-"
            spread = f"{h1['spread']:.3f}" if "spread" in h1 else "-"
            out.append(f"| {a} | {s} | {r['in_sample_best']:.1f} | {r['heldout_mean']:.1f} ({r['heldout_std']:.1f}) | "
                       f"{r['dt_half_coverage']:.1f} | {h0['mean']:.1f} | {h1['mean']:.1f} | {wall} | {spread} |")
    out.append("\nMean over seeds, and one-sided Mann-Whitney U (scipy.stats.mannwhitneyu, alternative "
               "'greater': PSO above random search) on the per-seed values:\n")
    out.append("| metric | " + " | ".join(arms) + " | " + " | ".join(f"{a} > random: U, p" for a in arms if a != "random")
               + " |")
    out.append("|---|" + "---|" * (len(arms) + len([a for a in arms if a != "random"])))
    for key, label in METRICS:
        vals = {a: [by[(a, s)][key] for s in seeds if (a, s) in by] for a in arms}
        cells = [f"{np.mean(v):.2f}" if v else "-" for v in vals.values()]
        tests = []
        for a in arms:
            if a == "random":
                continue
            if len(vals[a]) >= 2 and len(vals.get("random", [])) >= 2:
                t = mann_whitney(vals[a], vals["random"])
                tests.append(f"U = {t['U']:.0f}, p = {t['p']:.3f}")
            else:
                tests.append("-")
        out.append(f"| {label} | " + " | ".join(cells) + " | " + " | ".join(tests) + " |")
    return "\n".join(out) + "\n"


class CompareParams(BaseModel):
    robot: str = Field("lizard", description="modular robot (healthy)")
    seeds: str = Field("0,1,2,3,4", description="comma-separated seeds")
    arms: str = Field("constriction,random,paper", description="comma-separated arms: constriction, paper (PSO "
                                                                "presets), random")
    particles: int = Field(20, ge=2, le=1000, description="population per generation")
    generations: int = Field(20, ge=1, le=10000, description="generations (the budget is particles x generations)")
    heldout: int = Field(20, ge=1, le=500, description="held-out plans of each arm's best")
    gait_s: float = Field(30.0, gt=0.0, le=120.0, description="gait duration tau (paper: 30 s)")
    iterations: int = Field(150, ge=1, le=2000, description="RRT-MP iterations K (paper: 150)")
    out: Path = Field(Path("docs/multigait_compare.md"), description="markdown to write")
    json_out: Path = Field(Path("multigait_compare.json"), description="the runs (read first: runs there are kept)")
    report_only: bool = Field(False, description="only write the markdown from json_out")


def compare(p: CompareParams, log: Callable[[str], None] = print) -> str:
    done = json.loads(p.json_out.read_text()) if p.json_out.exists() else []
    if not p.report_only:
        arms = p.arms.split(",")
        seeds = [int(s) for s in p.seeds.split(",")]
        have = {(r["arm"], r["seed"]) for r in done}
        # PSO (non-paper) and random of a seed finish together; the paper's swarm runs last
        order = [(a, s) for s in seeds for a in arms if a != "paper"] + [("paper", s) for s in seeds if "paper" in arms]
        for arm, s in order:
            if (arm, s) in have:
                continue
            done.append(one(arm, p.robot, s, p.particles, p.generations, p.heldout, log, gait_s=p.gait_s,
                            iterations=p.iterations))
            p.json_out.write_text(json.dumps(done, indent=1))
    md = report(done)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(md)
    return md

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
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.evidence import control_seed
from app.jobs.ledger import code_version
from app.jobs.multigait.evidence import (CASES, COVERAGE_SHARE, gait_metrics, heldout_values, physics,
                                         robustness_target)
from app.jobs.multigait.planner.costs import evaluate
from app.jobs.multigait.planner.maps import get_map
from app.jobs.multigait.planner.primitives import ModularSim
from app.optim.pso import PRESETS, ParticleSwarm
from app.optim.random_search import RandomSearch
from app.robots.modular import get_shape


# the code that decides a run's numbers (``one`` below calls into these; ``code_version``
# hashes them into each appended run, so a ledger filled over sessions says which code ran)
SCIENCE = ("app/jobs/multigait/evidence.py", "app/jobs/multigait/cpg.py", "app/jobs/multigait/planner",
           "app/robots/modular/__init__.py", "app/optim/pso.py", "app/optim/random_search.py")


def make(arm: str, lower, upper, particles: int, seed: int):
    if arm == "random":
        return RandomSearch(lower, upper, particles, seed=control_seed(seed))
    return ParticleSwarm(lower, upper, particles, seed=seed, **PRESETS[arm])


def one(arm: str, robot: str, seed: int, particles: int, generations: int, heldout: int,
        log: Callable[[str], None] = print, gait_s: float = 30.0, settle_s: float = 1.0, iterations: int = 150) -> dict:
    """One arm on one seed: the paper's coverage problem (k = 3, tau = 30 s, K = 150, Empty)
    unless ``gait_s`` / ``iterations`` make it cheaper (tests)."""
    shape, pmap, sim = _problem(robot, gait_s, settle_s)
    k, K, radius = 3, iterations, shape.radius_mu()
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
    dt_half = next(c for c in CASES if c.name == "dt_half")
    sim2 = ModularSim(shape, (), pmap, gait_s, settle_s, physics=physics(dt_half))
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


def _empty_map():
    pmap = get_map("empty")
    return pmap.with_start_goal(pmap.start, (pmap.start[0] + 15.0, pmap.start[1], 0.5))


def _problem(robot: str, gait_s: float = 30.0, settle_s: float = 1.0):
    shape, pmap = get_shape(robot), _empty_map()
    return shape, pmap, ModularSim(shape, (), pmap, gait_s, settle_s)


def ruggedness(robot: str = "lizard", n: int = 40, seed: int = 1, streams: int = 8, iterations: int = 150,
               eps=(0.001, 0.01, 0.05), gait_s: float = 30.0) -> dict:
    """How much of the coverage of random gait sets is structure a search could follow:
    ``n`` uniform gait sets scored on the search's draws (stream 0), (a) planned again on
    ``streams`` other draw streams (planner noise) and (b) perturbed by Gaussian steps of
    ``eps`` x the box width per coordinate and simulated again (physics). Correlations of
    the cost between the originals and their re-plans / perturbations."""
    from app.jobs.multigait.planner.costs import _root_pose, cost_value, planner_draws
    from app.jobs.multigait.planner.rrt import composed_expander, rrt_mp

    shape, pmap, sim = _problem(robot, gait_s)
    radius = shape.radius_mu()
    try:
        lo, hi = sim.bounds(3)
        w = hi - lo
        rng = np.random.default_rng(seed)
        x = lo + rng.random((n, lo.size)) * w
        ev = evaluate(sim, x, 3, pmap, iterations, "coverage", 0, radius)
        f0 = ev.value
        replans = []
        for st in range(1, streams + 1):
            tree = rrt_mp(pmap, composed_expander(ev.prims), 3, planner_draws(0, n, iterations, stream=st), radius,
                          root_pose=_root_pose(sim))
            replans.append(cost_value(tree, "coverage", pmap))
        f = np.array(replans)
        out = {"n": n, "mean": float(f0.mean()), "std_between_sets": float(f0.std()),
               "planner": {"streams": streams, "corr": float(np.corrcoef(f0, f.mean(0))[0, 1]),
                           "std_within_set": float(f.std(0).mean())},
               "perturbed": []}
        for e in eps:
            xp = np.clip(x + rng.normal(size=x.shape) * e * w, lo, hi)
            e2 = evaluate(sim, xp, 3, pmap, iterations, "coverage", 0, radius)
            d0, d1 = ev.prims.distance().ravel(), e2.prims.distance().ravel()
            out["perturbed"].append({"eps": e, "corr": float(np.corrcoef(f0, e2.value)[0, 1]),
                                     "mean_abs_change": float(np.abs(f0 - e2.value).mean()),
                                     "gait_distance_corr": float(np.corrcoef(d0, d1)[0, 1]),
                                     "gait_distance_rel_change_median":
                                         float(np.median(np.abs(d1 - d0) / np.maximum(d0, 1e-3)))})
        return out
    finally:
        sim.close()


def robustness_of_bests(rows: list[dict], log: Callable[[str], None] = print) -> list[dict]:
    """Every arm's best of every seed re-simulated under the job's robustness cases."""
    from app.jobs.multigait.evidence import robustness_cases

    out = []
    for r in rows:
        shape, pmap = get_shape(r["robot"]), _empty_map()
        cases = robustness_cases(shape, (), pmap, r.get("gait_s", 30.0), 1.0, np.asarray(r["best_x"]), 3,
                                 r.get("iterations", 150), "coverage", r["seed"], shape.radius_mu())
        out.append({"arm": r["arm"], "seed": r["seed"], "nominal": r["in_sample_best"],
                    "cases": {c["name"]: c["metrics"]["coverage_pct"] for c in cases}})
        log(json.dumps(out[-1]))
    return out


def robustness_report(rob: list[dict]) -> str:
    names = list(rob[0]["cases"])
    lines = ["| arm | seed | nominal | " + " | ".join(names) + f" | cases >= {COVERAGE_SHARE * 100:g} % of nominal |",
             "|---|---|---|" + "---|" * (len(names) + 1)]
    for r in sorted(rob, key=lambda r: (r["arm"], r["seed"])):
        target = robustness_target("coverage", r["nominal"])
        met = sum(target.met({"coverage_pct": v}) for v in r["cases"].values())
        lines.append(f"| {r['arm']} | {r['seed']} | {r['nominal']:.1f} | "
                     + " | ".join(f"{r['cases'][n]:.1f}" for n in names) + f" | {met} / {len(names)} |")
    for arm in sorted({r["arm"] for r in rob}):
        sel = [r for r in rob if r["arm"] == arm]
        allv = [v for r in sel for v in r["cases"].values()]
        lines.append(f"| **{arm}: mean** | | {np.mean([r['nominal'] for r in sel]):.1f} | "
                     + " | ".join(f"{np.mean([r['cases'][n] for r in sel]):.1f}" for n in names)
                     + f" | mean over cases {np.mean(allv):.1f} |")
    return "\n".join(lines) + "\n"


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
    out: Path | None = Field(None, description="also write the markdown here (docs/multigait_compare.md is generated "
                                               "from the JSON by `gaitmend docs`)")
    json_out: Path = Field(Path("docs/multigait_compare.json"), description="the runs (read first: runs there are kept)")
    report_only: bool = Field(False, description="only write the markdown from json_out")
    robustness: bool = Field(False, description="also re-simulate every run's best under the job's robustness "
                                                "cases (dt/2, dt/4, friction x0.7/x1.3, masses -/+10 %)")


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
            before = os.getloadavg()[0]
            r = one(arm, p.robot, s, p.particles, p.generations, p.heldout, log, gait_s=p.gait_s,
                    iterations=p.iterations)
            # where and when it ran, so a ledger filled over several sessions says so per run
            done.append(r | {"code_version": code_version(SCIENCE), "cores": os.cpu_count(), "load_before": before,
                             "load_after": os.getloadavg()[0], "nice": os.nice(0),
                             "finished": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())})
            p.json_out.write_text(json.dumps(done, indent=1))
        if p.robustness:
            for r in done:
                if "robustness" not in r:
                    r["robustness"] = robustness_of_bests([r], log)[0]["cases"]
                    p.json_out.write_text(json.dumps(done, indent=1))
    md = report(done)
    rob = [{"arm": r["arm"], "seed": r["seed"], "nominal": r["in_sample_best"], "cases": r["robustness"]}
           for r in done if "robustness" in r]
    if rob:
        md += ("\nEach run's best re-simulated (robustness cases of the job), coverage % planned on the search's "
               "draws:\n\n" + robustness_report(rob))
    if p.out is not None:
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(md)
    return md


class RuggednessParams(BaseModel):
    robot: str = Field("lizard", description="modular robot (healthy)")
    n: int = Field(40, ge=3, le=1000, description="uniform random gait sets")
    seed: int = Field(1, ge=0, le=2**32 - 1, description="seed of the gait sets and perturbations")
    out: Path = Field(Path("docs/multigait_ruggedness.json"), description="JSON to write")


def ruggedness_experiment(p: RuggednessParams, log: Callable[[str], None] = print) -> str:
    t0, c0 = time.monotonic(), time.process_time()
    iterations, gait_s = 150, 30.0  # the paper's K and gait length, passed and recorded together
    r = ruggedness(p.robot, p.n, p.seed, iterations=iterations, gait_s=gait_s)
    r |= {"robot": p.robot, "seed": p.seed, "iterations": iterations, "gait_s": gait_s, "wall_s": time.monotonic() - t0,
          "cpu_s": time.process_time() - c0,
          "command": f"gaitmend reproduce multigait-ruggedness --robot {p.robot} --n {p.n} --seed {p.seed} --write-docs"}
    p.out.write_text(json.dumps(r, indent=1))
    lines = [f"{p.n} random gait sets ({p.robot}, coverage, K = 150): mean {r['mean']:.2f} %, std between sets "
             f"{r['std_between_sets']:.2f}",
             f"planner draws: corr(stream 0, mean of {r['planner']['streams']} other streams) = "
             f"{r['planner']['corr']:.3f}, std within a set {r['planner']['std_within_set']:.2f}"]
    for q in r["perturbed"]:
        lines.append(f"perturbed by {q['eps']:g} of the box width: corr {q['corr']:.2f}, mean |change| "
                     f"{q['mean_abs_change']:.2f}, gait distance corr {q['gait_distance_corr']:.2f}, median relative "
                     f"change {q['gait_distance_rel_change_median']:.2f}")
    return "\n".join(lines) + "\n"

"""Issue 24's comparison: the randomised robust search (spec ``randomised``) against the
nominal search at equal simulation budget, on the four Table II damages and several seeds,
each answer judged on the same held-out random models (drawn from the stated ranges with a
seed no search uses). `gaitmend reproduce recovery-randomised --write-docs`; every finished
search (one arm of one damage and seed) is appended to docs/recovery_randomised.json when it
ends, and a re-run skips those already there at this code version.

Equal budget: the randomised search of G generations simulates P x K x (2G + 1) walks (its
parents scored again on every draw); the nominal search gets K x (2G + 1) - 1 generations,
the same number of walks of the same length. A walk that falls stops early in either arm,
so the simulated steps, measured and reported per arm, can differ a little.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger, current_runs, machine_time
from app.jobs.recovery.reproduce import science_files
from app.jobs.recovery.reproduce.table2_damages import run_seed_major
from app.jobs.reporting import md_table, missing, progress_note

JSON = "docs/recovery_randomised.json"
COMMAND = "gaitmend reproduce recovery-randomised --write-docs"
SCIENCE = science_files.BASE + ("app/jobs/recovery/randomised.py", "app/optim/de.py")
KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "fell")
# The held-out models every answer is judged on: the held-out stream of a seed no search of
# this comparison uses (searches: seeds 0 .. seeds-1; their draws: cases.SEARCH_STREAM).
HELD_OUT_SEED = 10_000
ARMS = ("randomised", "nominal")
SCENARIOS = ((1, 6), (3, 4), (1,), (4,))  # Table II's four damages (experiments.SCENARIOS)


class RandomisedParams(BaseModel):
    seeds: int = Field(3, ge=1, le=100, description="seeds per damage (the issue asks >= 3)")
    population: int = Field(12, ge=4, le=1000, description="DE population of both arms")
    generations: int = Field(5, ge=1, le=1000, description="randomised search's generations (the nominal search "
                                                           "gets K x (2G + 1) - 1: the same walks)")
    models: int = Field(4, ge=2, le=32, description="K: random models drawn per generation")
    aggregate: str = Field("mean", pattern="^(mean|cvar)$", description="randomised fitness: mean or CVaR over K")
    cvar_share: float = Field(0.5, ge=0.1, le=1.0, description="cvar: the worst share averaged")
    walk_s: float = Field(5.0, ge=1.0, le=10.0, description="walk length during the searches (s)")
    mode: str = Field("open_loop", pattern="^(open_loop|closed_loop)$", description="how both arms drive the gait")
    held_out: int = Field(20, ge=20, le=200, description="held-out random models every answer is judged on")
    judge_walk_s: float = Field(10.0, ge=3.0, le=10.0, description="walk length of the held-out judgement (s)")
    json_out: Path | None = Field(Path(JSON), description="the ledger: each search is appended when it ends")


def nominal_generations(p: RandomisedParams) -> int:
    """The nominal search's generations for the randomised search's walks: K x (2G + 1) - 1."""
    return p.models * (2 * p.generations + 1) - 1


def arm_spec(p: RandomisedParams, lost: tuple[int, ...], seed: int, arm: str) -> dict:
    d = {"damage": {"lost_legs": list(lost)}, "sim": {"duration_s": p.walk_s}, "control": {"mode": p.mode},
         "search": {"population": p.population, "seed": seed,
                    "generations": p.generations if arm == "randomised" else nominal_generations(p)},
         "controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 0}}
    if arm == "randomised":
        d["randomised"] = {"models": p.models, "aggregate": p.aggregate, "cvar_share": p.cvar_share}
    return d


def judge(lost: tuple[int, ...], x: np.ndarray, p: RandomisedParams) -> dict:
    """The answer on the nominal model and the held-out models, ``judge_walk_s`` walks."""
    from app.jobs.recovery.evaluate import GaitEvaluator
    from app.jobs.recovery.metrics import target_met
    from app.jobs.recovery.robust import held_out
    from app.jobs.recovery.run import sim_config, sim_model
    from app.jobs.recovery.sequences import plan_hexapod
    from app.jobs.recovery.spec import RecoverySpec
    from app.robots.catalog import get_robot

    spec = RecoverySpec.parse({"damage": {"lost_legs": list(lost)}, "sim": {"duration_s": p.judge_walk_s},
                               "control": {"mode": p.mode}})
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    cfg = sim_config(spec)

    def met(m: dict) -> bool | None:
        return target_met(m, p.judge_walk_s)

    ev = GaitEvaluator(robot, model, seq, cfg)
    nominal = {k: (bool(v[0]) if k == "fell" else float(v[0])) for k, v in ev.evaluate(x).metrics.items() if k in KEEP}
    ev.close()
    ho, _ = held_out(mspec, robot, seq, cfg, x, HELD_OUT_SEED, p.held_out, met)
    models = [{k: m["metrics"][k] for k in KEEP} | {"target_met": m["target_met"]} for m in ho["models"]]
    return {"nominal": nominal | {"target_met": met(nominal)}, "held_out": models, "met": ho["met"], "n": ho["n"]}


def run_arm(p: RandomisedParams, lost: tuple[int, ...], seed: int, arm: str) -> dict:
    from app.jobs.base import MemoryContext
    from app.jobs.recovery.run import run
    from app.jobs.recovery.spec import RecoverySpec

    spec = RecoverySpec.parse(arm_spec(p, lost, seed, arm))
    s = run(spec, MemoryContext()).summary
    x = np.array(list(s["best"]["params"].values()))
    return {"arm": arm, "lost_legs": list(lost), "seed": seed, "generations": spec.search.generations,
            "walks": spec.search_walks, "evaluations": s["history"][-1]["evaluations"],
            "sim_steps": s["timing"]["sim_steps"], "search_wall_s": s["timing"]["wall_s"],
            "best_params": s["best"]["params"], "best_search_walk": {k: s["best"]["metrics"][k] for k in KEEP},
            "judged": judge(lost, x, p)}


def run_randomised(p: RandomisedParams, log: Callable[[str], None] = print) -> str:
    planned = len(SCENARIOS) * p.seeds * len(ARMS)
    led = Ledger(p.json_out, "recovery-randomised", COMMAND, p.model_dump(mode="json"), SCIENCE, planned=planned)
    run_seed_major(led, SCENARIOS, p.seeds, ARMS, lambda lost, seed, arm: ledger_spec(p, lost, seed, arm),
                   lambda lost, seed, arm: run_arm(p, lost, seed, arm), log)
    return render([led.data])


# -- the page ---------------------------------------------------------------------------------

def ledger_spec(p: RandomisedParams, lost: tuple[int, ...], seed: int, arm: str) -> dict:
    """A run's key spec in the ledger: the job's spec and the judgement's settings."""
    return arm_spec(p, lost, seed, arm) | {"held_out": p.held_out, "judge_walk_s": p.judge_walk_s}


def of_params(runs: list[dict], params: dict) -> list[dict]:
    """The runs made with the file's parameters (a run of another budget in the file is not tabled)."""
    p = RandomisedParams(**{k: v for k, v in params.items() if k != "json_out"})
    return [r for r in runs if r["spec"] == ledger_spec(p, tuple(r["result"]["lost_legs"]), r["seed"],
                                                        r["result"]["arm"])]


def _pairs(runs: list[dict]) -> dict[tuple, dict[str, dict]]:
    """{(damage, seed): {arm: result}} for the pairs with both arms in."""
    out: dict[tuple, dict[str, dict]] = {}
    for r in runs:
        res = r["result"]
        out.setdefault((tuple(res["lost_legs"]), res["seed"]), {})[res["arm"]] = res
    return {k: v for k, v in sorted(out.items()) if all(a in v for a in ARMS)}


def _rate(k: int, n: int) -> str:
    from app.jobs.recovery.reproduce.loop_check import wilson

    lo, hi = wilson(k, n)
    return f"{k}/{n} ({100 * k / n:.0f} %) [{max(0.0, 100 * lo):.0f}, {100 * hi:.0f}]" if n else "-"


def _median(rows: list[dict], key: str, scale: float) -> str:
    return f"{statistics.median(abs(scale * r[key]) for r in rows):.1f}" if rows else "-"


def _damage_rows(pairs: dict) -> list[list]:
    rows = []
    for lost in sorted({k[0] for k in pairs}, key=lambda l: (-len(l), l)):
        ps = [v for k, v in pairs.items() if k[0] == lost]
        c = {a: (sum(v[a]["judged"]["met"] for v in ps), sum(v[a]["judged"]["n"] for v in ps)) for a in ARMS}
        nom = {a: sum(bool(v[a]["judged"]["nominal"]["target_met"]) for v in ps) for a in ARMS}
        fell = {a: sum(m["fell"] for v in ps for m in v[a]["judged"]["held_out"]) for a in ARMS}
        diffs = [(v["randomised"]["judged"]["met"] - v["nominal"]["judged"]["met"]) for v in ps]
        rows.append([" & ".join(map(str, lost)), len(ps), _rate(*c["nominal"]), _rate(*c["randomised"]),
                     ", ".join(f"{d:+d}" for d in diffs), f"{nom['nominal']}/{len(ps)}",
                     f"{nom['randomised']}/{len(ps)}", f"{fell['nominal']} / {fell['randomised']}"])
    return rows


def render(datas: list) -> str:
    from app.jobs.stats import paired, paired_text

    data = datas[0]
    runs = of_params(current_runs(data), data["params"]) if data else []
    if not runs:
        return missing(JSON, COMMAND)
    p, pairs = data["params"], _pairs(runs)
    from app.jobs.recovery.reproduce.rejudge import old_floor_note

    stale = old_floor_note(runs, "the randomised searches (scored on random models with that floor) and every "
                                 "held-out figure below", COMMAND)
    gn = p["models"] * (2 * p["generations"] + 1) - 1
    walks = p["population"] * (gn + 1)
    agg = "mean" if p["aggregate"] == "mean" else f"CVaR of the worst {100 * p['cvar_share']:g} %"
    out = stale + [f"Randomised robust search (DE {p['population']} x {p['generations']}, K = {p['models']} random models per "
           f"generation, fitness the {agg} of Eq. 5 over them, parents scored again on every draw) against the nominal "
           f"search (DE {p['population']} x {gn}: the same {walks} walks), {p['walk_s']:g} s walks at the default step, {p['mode'].replace('_', ' ')}; each answer judged on "
           f"the same {p['held_out']} held-out random models (stated ranges, held-out stream of seed {HELD_OUT_SEED}, "
           f"not a search seed) over {p['judge_walk_s']:g} s walks against the target. "
           f"{len(runs)} of {data.get('planned')} planned searches are in ({len(pairs)} complete pairs).", ""]
    if not pairs:
        return "\n".join(out) + progress_note(data, len(runs))
    out += [md_table(["damage", "pairs (seeds)", "nominal search: held-out met [95 % Wilson]", "randomised search",
                      "per seed: randomised - nominal (models)", "nominal model met: nominal", "randomised",
                      "held-out falls: nominal / randomised"], _damage_rows(pairs))]
    share = {a: [v[a]["judged"]["met"] / v[a]["judged"]["n"] for v in pairs.values()] for a in ARMS}
    r = paired(share["randomised"], share["nominal"], names=("randomised search", "nominal search"))
    k = {a: (sum(v[a]["judged"]["met"] for v in pairs.values()), sum(v[a]["judged"]["n"] for v in pairs.values()))
         for a in ARMS}
    walks = {a: [m for v in pairs.values() for m in v[a]["judged"]["held_out"] if not m["fell"]] for a in ARMS}
    why = "; ".join(f"{a} search: {len(walks[a])} of {k[a][1]} held-out walks did not fall, of those median |lateral| "
                    f"{_median(walks[a], 'x_f_m', 100)} cm, |yaw| {_median(walks[a], 'yaw_f_deg', 1)} deg, forward "
                    f"{_median(walks[a], 'y_f_m', 100)} cm" for a in ("nominal", "randomised"))
    steps = {a: sum(v[a]["sim_steps"] for v in pairs.values()) for a in ARMS}
    wall = {a: sum(v[a]["search_wall_s"] for v in pairs.values()) for a in ARMS}
    out += ["All damages: held-out met, nominal search " + _rate(*k["nominal"]) + ", randomised search "
            + _rate(*k["randomised"]) + ". Paired difference of the held-out share (randomised - nominal, one pair per "
            "damage and seed): " + paired_text(r, digits=3) + ".", "",
            f"Where the held-out walks fail ({p['judge_walk_s']:g} s walks): {why}.", "",
            f"Budget, measured over the {len(pairs)} pairs: simulated steps nominal {steps['nominal']:,}, randomised "
            f"{steps['randomised']:,} (ratio {steps['randomised'] / max(steps['nominal'], 1):.2f}; walks that fall "
            f"stop early); search wall time {wall['nominal']:.0f} s and {wall['randomised']:.0f} s (the random models' "
            f"rough floor costs more per step). Machine time of all runs: {machine_time(data)['wall_s']:.0f} s wall.",
            progress_note(data, len(runs))]
    return "\n".join(out)

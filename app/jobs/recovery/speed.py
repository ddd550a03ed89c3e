"""Issue 22's measurements (`gaitmend reproduce recovery-speed`): where a step's time goes,
what cutting short the walks that cannot win DE's selection saves and whether it leaves the
answer alone, the fast preset's time to the target, and a configuration of equal quality
for less. Every run is written to the JSON file as it finishes, so an interrupted
measurement resumes where it stopped; docs/recovery_speed.md is made from that file."""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from app.core.host import machine, machine_text
from app.jobs.base import MemoryContext
from app.jobs.reporting import marked, missing
from app.jobs.recovery.metrics import target_met
from app.jobs.recovery.robust import held_out_walks
from app.jobs.recovery.run import run, set_up
from app.jobs.recovery.spec import RecoverySpec

SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]  # paper 000's Table II
ONLY_SEARCH = {"controls": {"random_search": False}, "robustness": {"cases": ["dt_half"], "held_out": 0}}
PAPER = {"search": {"population": 30, "generations": 60}}
# The equal-quality configuration: CMA-ES (the `cma` package behind the same ask/tell
# interface), 12 per generation, 1 ms; its first 48 generations walk 5 s, their displacements
# carried to 10 s (search.short_walks), then 36 generations of full 10 s walks: the steps of
# CMA-ES 12 x 60 on full walks (docs/recovery_speed.md has its runs and their wall times).
EQUAL = {"search": {"optimizer": "cmaes", "population": 12, "generations": 83,
                    "short_walks": {"walk_s": 5.0, "generations": 48}}}
# Other configurations (part name "alt_<name>"): the equal-quality configurations of before,
# CMA-ES 12 x 60 (before the faster step) and 12 x 82 (full walks); at about 12 x 60's budget,
# tried where it fell short (legs 3 & 4), a wider and a narrower CMA-ES generation and the
# paper's DE itself with a population of 12 and cut walks; and the short walks scored on their
# own F (without carrying them to 10 s). A run is labelled by the configuration it ran (its
# spec), so the runs of a configuration keep their label when EQUAL changes (``by_config``).
ALTERNATIVES = {
    "cmaes_12x60": {"search": {"optimizer": "cmaes", "population": 12, "generations": 60}},
    "cmaes_12x82": {"search": {"optimizer": "cmaes", "population": 12, "generations": 82}},
    "cmaes_20x36": {"search": {"optimizer": "cmaes", "population": 20, "generations": 36}},
    "cmaes_8x90": {"search": {"optimizer": "cmaes", "population": 8, "generations": 90}},
    "de_12x60_cut": {"search": {"population": 12, "generations": 60, "cut_walks": True}},
    "cmaes_12x83_short5_raw": {"search": {"optimizer": "cmaes", "population": 12, "generations": 83,
                                          "short_walks": {"walk_s": 5.0, "generations": 48, "extrapolate": False}}},
}
STAGES = ("mjTIMER_STEP", "mjTIMER_POSITION", "mjTIMER_POS_KINEMATICS", "mjTIMER_POS_INERTIA",
          "mjTIMER_POS_COLLISION", "mjTIMER_COL_BROAD", "mjTIMER_COL_NARROW", "mjTIMER_POS_MAKE", "mjTIMER_VELOCITY",
          "mjTIMER_ACTUATION", "mjTIMER_CONSTRAINT", "mjTIMER_ADVANCE")


def _uniform(job, n: int, seed: int = 0) -> np.ndarray:
    """``n`` candidates drawn uniformly in ``job``'s bounds from ``seed`` (the measurements' batches)."""
    return job.lower + np.random.default_rng(seed).random((n, job.lower.size)) * (job.upper - job.lower)


# -- where a step's time goes ------------------------------------------------------------------

def step_profile(model: mujoco.MjModel, d: mujoco.MjData | None = None, ctrl: np.ndarray | None = None,
                 settle: int = 1000, n: int = 1000, reps: int = 7) -> dict:
    """MuJoCo's own timers per stage (us per step, timers on) after ``settle`` steps from
    ``d``'s state: ``reps`` rounds of ``n`` steps, each stage's fastest round (another
    process taking the core inflates a round, never deflates it); and what a step holds
    (contacts, constraint rows, solver iterations)."""
    d = d if d is not None else mujoco.MjData(model)
    if ctrl is not None:
        d.ctrl[:] = ctrl
    for _ in range(settle):
        mujoco.mj_step(model, d)
    rounds, ncon, nefc, iters = [], 0, 0, 0
    for _ in range(reps):
        for t in d.timer:
            t.duration, t.number = 0.0, 0
        for _ in range(n):
            mujoco.mj_step(model, d)
            ncon, nefc, iters = ncon + d.ncon, nefc + d.nefc, iters + int(d.solver_niter[0])
        rounds.append({name.removeprefix("mjTIMER_").lower(): 1e6 * d.timer[int(getattr(mujoco.mjtTimer, name))].duration / n
                       for name in STAGES})
    stages = {k: min(r[k] for r in rounds) for k in rounds[0]}
    steps = n * reps
    return {"us_per_step": stages, "contacts": ncon / steps, "constraint_rows": nefc / steps,
            "solver_iterations": iters / steps, "ngeom": model.ngeom, "nv": model.nv, "timestep_s": model.opt.timestep}


def _standing(lost: tuple[int, ...]) -> tuple[mujoco.MjModel, mujoco.MjData, np.ndarray]:
    """The recovery robot with ``lost`` legs in its first pose (the nominal gait's), as a walk starts."""
    from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
    from app.jobs.recovery.run import functional_legs, nominal_params, sim_model
    from app.jobs.recovery.sequences import nominal_tripod
    from app.robots.catalog import get_robot

    spec = RecoverySpec(damage={"lost_legs": list(lost)})
    robot = get_robot(spec.robot)
    _, model = sim_model(spec, robot)
    legs = functional_legs(spec)
    ev = GaitEvaluator(robot, model, nominal_tripod(legs), SimConfig(nthread=1))
    period, state = ev.period_controls(nominal_params(robot, legs)[None])
    ev.close()
    d = mujoco.MjData(model)
    mujoco.mj_setState(model, d, state[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return model, d, period[0, 0]


def profiles() -> list[dict]:
    """The recovery robot intact and with the Table II damages, standing in its first pose;
    then the other built-in robots as their kinds build them (no control: a first look)."""
    from app.robots import heavy_hexapod, quadruped, silo6

    rows = [{"robot": "jethexa", "damage": list(lost)} | step_profile(*_standing(lost)) for lost in [()] + SCENARIOS]
    for name, model in (("heavy_hexapod", heavy_hexapod.build_tilt_spec().compile()),
                        ("silo6", silo6.build_flat_spec().compile()), ("quadruped", quadruped.build_model())):
        rows.append({"robot": name, "damage": []} | step_profile(model))
    return rows


# -- physics settings tried ------------------------------------------------------------------------

def _disable(bit):
    def edit(m):
        m.opt.disableflags |= int(bit)
    return edit


def _set_opt(name, value):
    def edit(m):
        setattr(m.opt, name, value)
    return edit


def _no_fall_collisions(m):
    """Only the feet collide (chassis, coxae and femurs no longer touch the floor)."""
    for g in range(m.ngeom):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        if name and name != "floor" and not name.endswith("_foot"):
            m.geom_conaffinity[g] = 0


VARIANTS: dict[str, Callable[[mujoco.MjModel], None]] = {
    "solver tolerance 1e-6 (was 1e-8)": _set_opt("tolerance", 1e-6),
    "line-search iterations 5 (was 50)": _set_opt("ls_iterations", 5),
    "solver iterations 1 (was 100)": _set_opt("iterations", 1),
    "PGS solver (was Newton)": _set_opt("solver", mujoco.mjtSolver.mjSOL_PGS),
    "Euler integrator (was implicitfast)": _set_opt("integrator", mujoco.mjtIntegrator.mjINT_EULER),
    "no island discovery": _disable(mujoco.mjtDisableBit.mjDSBL_ISLAND),
    "no control clamping": _disable(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL),
    "feet the only colliding geoms": _no_fall_collisions,
    "unchanged (a second copy: the noise)": lambda m: None,
}


def _cpu_us_per_step(models: dict[str, mujoco.MjModel], state: np.ndarray, ctrl: np.ndarray, reps: int) -> dict:
    """Single-thread CPU time per step (thread time, so other work on the machine counts
    less), the runs interleaved in a new order each round; the 25th percentile of each."""
    from mujoco import rollout

    times: dict[str, list[float]] = {n: [] for n in models}
    rng = np.random.default_rng(0)
    for _ in range(reps):
        for name in rng.permutation(list(models)):
            d = mujoco.MjData(models[name])
            t = time.thread_time()
            rollout.rollout(models[name], d, state, ctrl)
            times[name].append(1e6 * (time.thread_time() - t) / (ctrl.shape[0] * ctrl.shape[1]))
    return {n: float(np.percentile(v, 25)) for n, v in times.items()}


def variants(reps: int = 15, docs: Path = Path("docs")) -> dict:
    """Each physics setting of VARIANTS on the default damaged model (legs 1 & 6): CPU time
    per step against the model as it is, and what it does to the documented answers
    (re-simulated at the default step: bit-identical, or the largest change)."""
    from app.jobs.recovery.answers import answers_metrics, documented_answers
    from app.jobs.recovery.run import set_up, sim_model

    job = set_up(RecoverySpec(**ONLY_SEARCH))
    x = _uniform(job, 8)
    ctrl, state = job.ev.controls(x)
    job.close()
    # the model as these settings were tried: before the explicit contact pairs (pairs_row), so
    # "feet the only colliding geoms" still has a broad phase to act on
    broad = sim_model(job.spec, job.robot, **STEP_SETTINGS["broad phase, island discovery (before)"])[1]
    models = {"as it is": broad}
    for name, edit in VARIANTS.items():
        m = broad.__copy__()
        edit(m)
        models[name] = m
    us = _cpu_us_per_step(models, state, ctrl[:, :1500], reps)
    dt = RecoverySpec().sim.timestep_s
    answers = documented_answers(dt, docs)
    before = STEP_SETTINGS["broad phase, island discovery (before)"]
    base = answers_metrics(answers, dt, settings=before)
    rows = []
    for name, edit in VARIANTS.items():
        got = answers_metrics(answers, dt, edit=edit, settings=before)
        same = all(np.array_equal(base[k], got[k]) for k in base)
        rows.append({"variant": name, "us_per_step": us[name], "speedup": us["as it is"] / us[name], "identical": same,
                     "max_forward_cm": float(100 * np.max(np.abs(got["y_f_m"] - base["y_f_m"]))),
                     "max_lateral_cm": float(100 * np.max(np.abs(got["x_f_m"] - base["x_f_m"]))),
                     "max_yaw_deg": float(np.max(np.abs(got["yaw_f_deg"] - base["yaw_f_deg"])))})
    return {"part": "variants", "reference_us_per_step": us["as it is"], "answers": len(answers), "rows": rows,
            "load": os.getloadavg()[0]}


# the step's settings, from before to now (RobotEntry.model): each adds one change to the last;
# the names are the keys of the recorded rows ("(now)" marks what was the last when first recorded)
STEP_SETTINGS = {"broad phase, island discovery (before)": {"pairs": False, "islands": True, "merged_fall": False},
                 "explicit contact pairs": {"pairs": True, "islands": True, "merged_fall": False},
                 "explicit contact pairs, no island discovery (now)": {"pairs": True, "islands": False,
                                                                       "merged_fall": False},
                 "one fall-contact sensor": {"pairs": True, "islands": False, "merged_fall": True}}


def pairs_row(reps: int = 15, docs: Path = Path("docs")) -> dict:
    """The step's settings of STEP_SETTINGS (app/robots/contacts.py's explicit robot-floor
    pairs, then no constraint-island discovery, then the fall test's one contact sensor),
    each against the one before: single-thread CPU time per step on each Table II damage (8
    random candidates, 1.5 s walks, all settings interleaved), and whether every documented
    answer re-simulated at the default step is the same bit for bit as before them."""
    from app.jobs.recovery.answers import answers_metrics, documented_answers
    from app.jobs.recovery.run import set_up, sim_model
    from app.robots.catalog import get_robot

    damages = []
    for lost in SCENARIOS:
        spec = RecoverySpec(damage={"lost_legs": list(lost)}, **ONLY_SEARCH)
        job = set_up(spec)
        x = _uniform(job, 8)
        ctrl, state = job.ev.controls(x)
        job.close()
        models = {name: sim_model(spec, get_robot(spec.robot), **s)[1] for name, s in STEP_SETTINGS.items()}
        damages.append({"lost_legs": list(lost), "us_per_step": _cpu_us_per_step(models, state, ctrl[:, :1500], reps)})
    dt = RecoverySpec().sim.timestep_s
    answers = documented_answers(dt, docs)
    got = {name: answers_metrics(answers, dt, settings=s) for name, s in STEP_SETTINGS.items()}
    before = got[next(iter(STEP_SETTINGS))]
    return {"part": "pairs", "damages": damages, "answers": len(answers),
            "identical": {name: all(np.array_equal(before[k], m[k]) for k in before) for name, m in got.items()},
            "load": os.getloadavg()[0], "cores": os.cpu_count()}


def scaling_row(generations: int = 5, reps: int = 3) -> dict:
    """Where the exact paper DE's time goes, on legs 1 & 6: a DE of the paper's population
    for ``generations`` generations with every rollout call timed (the share of its wall time
    inside mujoco.rollout, steps/s there and overall), and one 1000-step chunk of 30 random
    candidates rolled out on one thread and on the evaluator's threads (medians of ``reps``,
    interleaved): how far the threads scale on this machine."""
    from app.jobs.evidence import Phases
    from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
    from app.jobs.recovery.run import phase_sizes, search, set_up

    spec = RecoverySpec(damage={"lost_legs": [1, 6]}, search={"population": PAPER["search"]["population"],
                                                              "generations": generations}, **ONLY_SEARCH)
    job = set_up(spec)
    inside = [0.0]

    def timed(call):
        def run_timed(*args):
            t = time.perf_counter()
            try:
                return call(*args)
            finally:
                inside[0] += time.perf_counter() - t
        return run_timed

    try:
        for e in job.score.ev.evaluators:
            e._rollout = timed(e._rollout)
        t = time.perf_counter()
        search(job, Phases(MemoryContext(), phase_sizes(spec)))
        wall = time.perf_counter() - t
        steps = int(job.searches["search"].totals.get("sim_steps", 0))
        x = _uniform(job, 30)
        one = GaitEvaluator(job.robot, job.model, job.seq, SimConfig(nthread=1))
        ctrl, state = job.ev.controls(x)
        ctrl = np.ascontiguousarray(ctrl[:, :1000])
        rates: dict[int, list[float]] = {1: [], job.ev.nthread: []}
        for _ in range(reps):
            for ev in (one, job.ev):
                t = time.perf_counter()
                ev._rollout([job.model], state, ctrl)
                rates[ev.nthread].append(ctrl.shape[0] * ctrl.shape[1] / (time.perf_counter() - t))
        one.close()
    finally:
        job.close()
    single, multi = statistics.median(rates[1]), statistics.median(rates[job.ev.nthread])
    return {"part": "scaling", "generations": generations, "population": spec.search.population, "wall_s": wall,
            "in_rollout_s": inside[0], "sim_steps": steps, "threads": job.ev.nthread, "one_thread_steps_per_s": single,
            "threads_steps_per_s": multi, "load": os.getloadavg()[0], "cores": os.cpu_count()}


def scaling_markdown(r: dict, paper_steps: float | None = None, bench_s: float | None = None) -> list[str]:
    """``paper_steps``: the exact paper DE's simulated steps (its runs on the page), for the
    wall time this run's overall rate gives it; ``bench_s``: the last bench's measured one."""
    share = r["in_rollout_s"] / r["wall_s"]
    overall = r["sim_steps"] / r["wall_s"]
    at_rate = ("" if paper_steps is None else
               f" The exact paper DE simulates {paper_steps / 1e6:.2f} M steps (median of its runs below): "
               f"{paper_steps / overall:.0f} s at this run's overall rate"
               + ("." if bench_s is None else f", against {bench_s:.1f} s measured by the last bench "
                                              f"({paper_steps / bench_s:,.0f} steps/s over the whole run)."))
    return [f"Where the exact paper DE's time goes (`gaitmend reproduce recovery-speed --parts scaling`, load "
            f"{r['load']:.1f} on {r['cores']} cores): a DE of {r['population']} for {r['generations']} generations on "
            f"legs 1 & 6 spent {100 * share:.1f} % of its {r['wall_s']:.1f} s inside `mujoco.rollout`, at "
            f"{r['sim_steps'] / r['in_rollout_s']:,.0f} steps/s there and {overall:,.0f} overall; "
            f"the rest is the evaluator's Python (controls, copies, fall tests, metrics) and the search's. One "
            f"1000-step chunk of 30 candidates rolls out at {r['one_thread_steps_per_s']:,.0f} steps/s on one thread "
            f"and {r['threads_steps_per_s']:,.0f} on {r['threads']}: the threads scale "
            f"{r['threads_steps_per_s'] / r['one_thread_steps_per_s']:.2f}x.{at_rate}", ""]


# -- the cut walks' speed cap ----------------------------------------------------------------------

def speed_ratios(lost, n: int = 60, seed: int = 1) -> dict:
    """For ``n`` uniform random candidates that do not fall: the largest ratio of a walk's
    mean forward speed over the rest of the walk (from each chunk's end) to its nominal speed
    (step length per gait period), the quantity CUT_SPEED_FACTOR bounds."""
    from app.jobs.recovery.run import set_up

    job = set_up(RecoverySpec(damage={"lost_legs": list(lost)}, **ONLY_SEARCH))
    try:
        ev = job.ev
        x = _uniform(job, n, seed)
        sens, end, _, steps = ev.simulate(x)
    finally:
        job.close()
    y = ev._sensor(sens, "com_pos")[..., 1]
    chunk = int(round(ev.cfg.chunk_s / ev.dt))
    stops = np.arange(chunk, ev.nstep, chunk)
    rest = (y[:, -1:] - y[:, stops - 1]) / ((ev.nstep - stops) * ev.dt)  # (n, chunks) m/s
    ratio = rest / (x[:, -2:-1] / ev.cfg.period_s)
    walkers = end == ev.nstep
    return {"part": "cap", "lost_legs": list(lost), "seed": 0, "draw_seed": seed, "walkers": int(walkers.sum()),
            "candidates": n,
            "max_ratio": float(ratio[walkers].max()), "p99_ratio": float(np.percentile(ratio[walkers].max(axis=1), 99)),
            "sim_steps": int(steps), "load": os.getloadavg()[0]}


# -- searches ------------------------------------------------------------------------------------

def _table2_rows(docs: Path) -> list[dict]:
    path = docs / "table2.json"
    return json.loads(path.read_text()) if path.exists() else []


def _documented(lost, seed: int, table2: list[dict]) -> dict | None:
    """Table II's (docs/table2.json's rows) paper-budget answer for this damage and seed at the default step."""
    dt = RecoverySpec().sim.timestep_s
    for r in table2:
        if (tuple(r["lost_legs"]) == tuple(lost) and r["seed"] == seed and r.get("timestep_s") == dt
                and r.get("generations") == 60 and r.get("population") == 30 and "best_params" in r):
            return r
    return None


def _search_row(part: str, lost, seed: int, data: dict) -> dict:
    d = json.loads(json.dumps({**ONLY_SEARCH, **data}))
    d["damage"] = {"lost_legs": list(lost)}
    d.setdefault("search", {})["seed"] = seed
    t = time.perf_counter()
    s = run(RecoverySpec(**d), MemoryContext()).summary
    wall = time.perf_counter() - t
    half = next((c for c in (s.get("robustness") or {}).get("cases", []) if c["name"] == "dt_half"), None)
    return {"part": part, "lost_legs": list(lost), "seed": seed, "spec": d, "wall_s": wall,
            "fitness": s["best"]["fitness"], "metrics": s["best"]["metrics"], "params": s["best"]["params"],
            "target_met": s["best"]["target_met"], "half_step_met": None if half is None else half["target_met"],
            "search": s["search"], "evaluations": s["timing"]["evaluations"], "sim_steps": s["timing"]["sim_steps"],
            "cut_steps_saved": s["timing"].get("cut_steps_saved", 0),
            "time_to_target_s": s["timing"].get("time_to_target_s"),
            "curve": [[r["generation"], r["best"], r["evaluations"]] for r in s["history"] if not r.get("provisional")],
            "walks_cut": sum(r.get("cut", 0) for r in s["history"]),
            "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}


def paper_row(lost, seed: int, docs: Path) -> dict:
    """The paper's DE (30 x 60, 10 s walks) with its losing walks cut short; for a seed the
    docs hold (Table II), whether the answer is the full-walk run's, bit for bit."""
    r = _search_row("paper", lost, seed, PAPER | {"search": PAPER["search"] | {"cut_walks": True}})
    doc = _documented(lost, seed, _table2_rows(docs))
    r["documented_params"] = None if doc is None else doc["best_params"]
    r["identical_to_documented"] = None if doc is None else doc["best_params"] == r["params"]
    return r


def check_rows(docs: Path, log: Callable[[str], None] = print, done: set | None = None):
    """Every nominal answer of docs/recovery_robust_w20.json at the default step (DE 12 x 12
    on every feasible 1- and 2-leg loss) searched again with cut walks: same answer?"""
    dt = RecoverySpec().sim.timestep_s
    path = docs / "recovery_robust_w20.json"
    for doc in json.loads(path.read_text()) if path.exists() else []:
        if doc["mode"] != "nominal" or doc["timestep_s"] != dt or (done and tuple(doc["lost_legs"]) in done):
            continue
        data = {"search": {"population": doc["population"], "generations": doc["generations"], "cut_walks": True},
                "objective": {"weights": doc["weights"]}, "robustness": {"cases": []}}
        r = _search_row("check", tuple(doc["lost_legs"]), doc["seed"], data)
        r["identical_to_documented"] = r["params"] == doc["best_params"]
        log(f"check legs {doc['lost_legs']}: same answer as recovery_robust_w20.json: {r['identical_to_documented']}, "
            f"{r['cut_steps_saved']} of {r['sim_steps'] + r['cut_steps_saved']} steps saved")
        yield r


def control_row(lost, seed: int, docs: Path) -> dict:
    """The random-search control of the paper-size job (30 x 60 after the first generation,
    the control's own stream of ``seed``) with its walks cut once they cannot beat its best
    so far (``controls.cut_walks``), then with full walks, on the same job: the same best
    bit for bit? Its steps and wall time both ways, and Table II's documented control F for
    this seed beside them."""
    from app.jobs.recovery.run import random_control, set_up

    spec = RecoverySpec(damage={"lost_legs": list(lost)}, search={"seed": seed}, **ONLY_SEARCH)
    job = set_up(spec)
    out = {}
    try:
        for name, cuts in (("cut", True), ("full", False)):
            t = time.perf_counter()
            o = random_control(job, PAPER["search"]["generations"], MemoryContext(), cuts=cuts)
            out[name] = {"fitness": o.best_fitness, "params": o.best_x.tolist(), "evaluations": o.evaluations,
                         "sim_steps": int(o.totals["sim_steps"]),
                         "cut_steps_saved": int(o.totals.get("cut_steps_saved", 0)),
                         "walks_cut": sum(r.get("cut", 0) for r in o.history), "wall_s": time.perf_counter() - t}
    finally:
        job.close()
    doc = _documented(lost, seed, _table2_rows(docs))
    cut, full = out["cut"], out["full"]
    return {"part": "control", "lost_legs": list(lost), "seed": seed, **out,
            "identical": cut["params"] == full["params"] and cut["fitness"] == full["fitness"],
            "documented_fitness": doc["random_search"]["fitness"] if doc and doc.get("random_search") else None,
            "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}


def coarse_row(lost, seed: int, docs: Path) -> dict:
    """Coarse-to-fine's first half: the equal-quality configuration searched at twice the
    step (half the steps per walk), its answer then judged at the default step."""
    from app.jobs.recovery.answers import answers_metrics
    from app.jobs.recovery.metrics import TARGET, fitness

    dt = RecoverySpec().sim.timestep_s
    cfg = EQUAL | {"search": EQUAL["search"] | {"generations": 2 * EQUAL["search"]["generations"]},
                   "sim": {"timestep_s": 2 * dt}}
    r = _search_row("coarse", lost, seed, cfg)
    m = answers_metrics([{"lost_legs": list(lost), "best_params": r["params"]}], dt)
    w = RecoverySpec().objective
    r["at_default_step"] = {"fitness": float(fitness(m, w.weights, w.units)[0]),
                            "metrics": {k: v[0].item() for k, v in m.items()},
                            "target_met": TARGET.met({k: v[0] for k, v in m.items()})}
    return r


def throughput(spec: RecoverySpec, repeats: int = 2) -> dict:
    """(a-c) on the spec's population of uniform random candidates."""
    from mujoco import rollout

    from app.jobs.recovery.run import set_up

    job = set_up(spec)
    ev = job.ev
    x = _uniform(job, spec.search.population)
    ctrl, state = ev.controls(x)
    # the raw rollout writes into arrays allocated and touched beforehand, so it times the
    # simulation, not the first touch of a few hundred MB of fresh output
    out = {"state": np.zeros((ctrl.shape[0], ctrl.shape[1], ev._nstate)),
           "sensordata": np.zeros((ctrl.shape[0], ctrl.shape[1], ev.model.nsensordata))}
    raw, evaluator = [], []
    try:
        with rollout.Rollout(nthread=ev.nthread) as runner:
            runner.rollout(ev.model, ev._datas, state, ctrl[:, :10])  # warm the pool
            for _ in range(repeats):  # interleaved, so a change of load hits both alike
                t = time.perf_counter()
                runner.rollout(ev.model, ev._datas, state, ctrl, **out)
                raw.append(ctrl.shape[0] * ctrl.shape[1] / (time.perf_counter() - t))
                t = time.perf_counter()
                r = ev.evaluate(x)
                evaluator.append(r.sim_steps / (time.perf_counter() - t))
    finally:
        job.close()
    a, b = float(np.median(raw)), float(np.median(evaluator))
    # the step's settings measured (RobotEntry.model: explicit contact pairs, island discovery)
    step = {"contact_pairs": int(job.model.npair),
            "island_discovery": not job.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND}
    return {"raw_steps_per_s": a, "evaluator_steps_per_s": b, "ratio": b / a, "threads": ev.nthread, "step": step}


def throughput_row() -> dict:
    """The bench's (a-c): raw rollout and evaluator steps/s on legs 1 & 6, interleaved."""
    spec = RecoverySpec(damage={"lost_legs": [1, 6]}, sim={"duration_s": 5.0}, **ONLY_SEARCH)
    return {"part": "throughput"} | throughput(spec, repeats=3) | {"load": os.getloadavg()[0]}


def _labels() -> list[tuple[str, dict]]:
    """Each searched configuration's part name: "equal" for EQUAL, "alt_<name>" for ALTERNATIVES."""
    return [("equal", EQUAL)] + [(f"alt_{n}", c) for n, c in ALTERNATIVES.items()]


def _config(row: dict) -> dict:
    return {k: v for k, v in row["spec"]["search"].items() if k != "seed"}


def by_config(rows: list[dict]) -> list[dict]:
    """The rows with each equal-quality or alternative run labelled by the configuration its
    spec holds: "equal" for EQUAL's, "alt_<name>" for ALTERNATIVES' (what the label was when
    it ran does not matter)."""
    out = []
    for r in rows:
        if r["part"] == "equal" or r["part"].startswith("alt_"):
            part = next((name for name, cfg in _labels() if _config(r) == cfg["search"]), r["part"])
            r = r | {"part": part}
        out.append(r)
    return out


PARTS: dict[str, Callable[..., dict]] = {
    "coarse": coarse_row,
    "cap": lambda lost, seed, docs: speed_ratios(lost, seed=seed + 1),
    "paper": paper_row,
    "control": control_row,
    "fast": lambda lost, seed, docs: _search_row("fast", lost, seed, {"preset": "fast"}),
    "equal": lambda lost, seed, docs: _search_row("equal", lost, seed, EQUAL),
} | {f"alt_{name}": (lambda cfg, part: lambda lost, seed, docs: _search_row(part, lost, seed, cfg))(cfg, f"alt_{name}")
     for name, cfg in ALTERNATIVES.items()}


def measure(parts: list[str], seeds: int, damages: list[tuple[int, ...]], raw: Path, docs: Path,
            log: Callable[[str], None] = print) -> list[dict]:
    """Every (part, damage, seed) not yet in ``raw``, seed by seed, each written at once;
    "profile" measures the step again."""
    rows = json.loads(raw.read_text()) if raw.exists() else []
    done = {(r["part"], tuple(r["lost_legs"]), r["seed"]) for r in by_config(rows) if r["part"] in PARTS}
    if "profile" in parts:
        rows = [r for r in rows if r["part"] != "profile"] + [{"part": "profile", "rows": profiles(),
                                                              "load": os.getloadavg()[0], "cores": os.cpu_count()}]
        _save(rows, raw)
        log("step profile measured")
    if "check" in parts:
        checked = {tuple(r["lost_legs"]) for r in rows if r["part"] == "check"}
        for r in check_rows(docs, log, checked):
            rows.append(r)
            _save(rows, raw)
    if "throughput" in parts:
        rows = [r for r in rows if r["part"] != "throughput"] + [throughput_row()]
        _save(rows, raw)
    if "scaling" in parts:  # kept beside earlier ones, as the variants
        rows.append(scaling_row())
        _save(rows, raw)
        log(scaling_markdown(rows[-1])[0])
    if "pairs" in parts:  # kept beside earlier ones, as the variants
        rows.append(pairs_row(docs=docs))
        _save(rows, raw)
        log(f"step settings: {rows[-1]['damages']}, answers identical: {rows[-1]['identical']}")
    if "variants" in parts:  # each measurement is kept: the machine's noise shows between them
        rows.append(variants(docs=docs))
        _save(rows, raw)
        log("physics variants measured")
    seeds_of = {"cap": 1, "coarse": 1}  # the speed cap and the coarse search: once per damage
    for seed in range(seeds):
        for lost in damages:
            for part in [p for p in parts if p in PARTS]:
                if (part, tuple(lost), seed) in done or seed >= seeds_of.get(part, seeds):
                    continue
                rows.append(PARTS[part](lost, seed, docs))
                _save(rows, raw)
                r = rows[-1]
                if part == "cap":
                    log(f"cap legs {lost}: largest ratio {r['max_ratio']:.2f} over {r['walkers']} walks")
                    continue
                if part == "control":
                    log(f"control legs {lost} seed {seed}: same best {r['identical']}, F {r['cut']['fitness']:.2f}, "
                        f"steps {r['cut']['sim_steps']} against {r['full']['sim_steps']}, "
                        f"{r['cut']['wall_s']:.0f} s against {r['full']['wall_s']:.0f} s at load {r['load']:.1f}")
                    continue
                log(f"{part} legs {lost} seed {seed}: F {r['fitness']:.2f}, target {r['target_met']} (half step "
                    f"{r['half_step_met']}), {r['search']['stop_reason']} after {r['search']['generations_run']} "
                    f"generations, {r['sim_steps']} steps, {r['wall_s']:.0f} s at load {r['load']:.1f}")
    if "perturbed" in parts:  # after the searches above: it re-walks their answers (every seed that has all three)
        have = {(tuple(r["lost_legs"]), r["seed"]) for r in rows if r["part"] == "perturbed"}
        for r in perturbed_rows(rows, _table2_rows(docs), damages, have):
            rows.append(r)
            _save(rows, raw)
            log(f"perturbed legs {r['lost_legs']} seed {r['seed']}: " + ", ".join(
                f"{name} {sum(v['cases_met'])}/{len(v['cases_met'])} cases, {v['held_out_met']}/{r['held_out_n']} "
                "held out" for name, v in r["sets"].items()))
    return rows


def append_part(raw: Path, row: dict) -> None:
    """``row`` after the file's rows: a measurement made again is kept beside the earlier
    ones (each with its load: on a shared machine one measurement is not the machine's)."""
    rows = json.loads(raw.read_text()) if raw.exists() else []
    _save(rows + [row], raw)


def _save(rows: list[dict], raw: Path) -> None:
    raw.parent.mkdir(parents=True, exist_ok=True)
    tmp = raw.with_suffix(".part")
    tmp.write_text(json.dumps(rows, indent=1))
    tmp.replace(raw)


# -- the page ------------------------------------------------------------------------------------

def _name(lost) -> str:
    return ("legs " if len(lost) > 1 else "leg ") + " & ".join(str(l) for l in lost)


def _spread(values: list[float], fmt: str = "{:.1f}") -> str:
    if not values:
        return "-"
    return f"{fmt.format(statistics.median(values))} [{fmt.format(min(values))}, {fmt.format(max(values))}]"


def profile_markdown(block: dict) -> list[str]:
    """The step profile as measured (the machine's cores where the block recorded them)."""
    cores = f" on {block['cores']} cores" if block.get("cores") else ""
    cols = ["step", "position", "pos_kinematics", "pos_inertia", "col_broad", "col_narrow", "pos_make", "velocity",
            "actuation", "constraint", "advance"]
    out = [f"Step profile (MuJoCo's timers, us per step with the timers on, single thread, each stage's fastest of "
           f"7 rounds of 1000 steps; load {block['load']:.1f}{cores} while measured, so compare "
           "the shares more than the absolute times). The recovery robot stands in its first pose; the other "
           "built-in robots as their kinds build them, without control (a first look only):", "",
           "| robot | damage | " + " | ".join(cols) + " | contacts | rows | solver iterations |",
           "|---" * (len(cols) + 5) + "|"]
    for r in block["rows"]:
        t = r["us_per_step"]
        out.append(f"| {r['robot']} | {_name(r['damage']) if r['damage'] else 'none'} | "
                   + " | ".join(f"{t[c]:.1f}" for c in cols)
                   + f" | {r['contacts']:.1f} | {r['constraint_rows']:.1f} | {r['solver_iterations']:.2f} |")
    return out + [""]


def variants_markdown(blocks: list[dict]) -> list[str]:
    loads = " | ".join(f"speed-up at load {b['load']:.1f}" for b in blocks)
    ref = ", ".join(f"{b['reference_us_per_step']:.1f}" for b in blocks)
    last = blocks[-1]
    out = [f"Physics settings tried on the default damaged model (legs 1 & 6): single-thread CPU time per step "
           f"against the model as it was then (MuJoCo's broad phase and island discovery, before the two changes "
           f"above; {ref} us in the measurements below), each measured {len(blocks)} time(s) "
           f"on the shared machine (the unchanged copy shows the noise), and the {last['answers']} documented "
           "answers re-simulated at the default step with the setting. At these loads none was both faster beyond "
           "the noise and free of changes to the answers; no island discovery, measured again on an idle machine "
           "with the changes table's method, is the one adopted since (its row above):", "",
           f"| setting | {loads} | documented answers | largest change forward / lateral (cm) / yaw (deg) |",
           "|---" * (len(blocks) + 3) + "|"]
    for i, r in enumerate(last["rows"]):
        ups = " | ".join(f"{b['rows'][i]['speedup']:.2f}" for b in blocks)
        out.append(f"| {r['variant']} | {ups} | {'bit-identical' if r['identical'] else 'move'} | "
                   f"{r['max_forward_cm']:.1f} / {r['max_lateral_cm']:.1f} / {r['max_yaw_deg']:.1f} |")
    return out + [""]


def coarse_markdown(rows: list[dict]) -> list[str]:
    cfg = {k: v for k, v in _config(rows[0]).items() if k != "generations"}
    out = [f"Coarse-to-fine, first half: the equal-quality configuration of its time (`{json.dumps(cfg)}`) searched "
           "at twice the default step for twice the generations (about as many steps), its answer judged at the "
           "default step. The refinement at "
           "the default step would have to recover more F than searching at the default step from the start gives "
           "for the same steps, so coarse-to-fine was not built:", "",
           "| damage | seed | F at the coarse step | F at the default step | target at the coarse step / default "
           "step | yaw (deg) at the default step | steps |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["at_default_step"]
        out.append(f"| {_name(r['lost_legs'])} | {r['seed']} | {r['fitness']:.2f} | {d['fitness']:.2f} | "
                   f"{'yes' if r['target_met'] else 'no'} / {'yes' if d['target_met'] else 'no'} | "
                   f"{d['metrics']['yaw_f_deg']:.1f} | {r['sim_steps']:,} |")
    return out + [""]


def alternatives_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage and configuration: F over its seeds against the paper DE's on the same
    seeds, and its answers meeting the target at the default step and at half of it."""
    out = ["The equal-quality configuration and every other one tried, on the damages they were run on (walks: its "
           "budget; steps: what its runs simulated, fewer with short walks; the paper DE's F: its runs on this page, "
           "else docs/table2.json's for that seed; a configuration counts as equal quality when its median F over "
           "the seeds is at least the paper DE's median over the same seeds and its answers meet the target also at "
           "half the step):", "",
           "| damage | configuration | walks (steps, median) | F, median [range] (seeds) | paper DE F on those seeds | "
           ">= paper, same seed | target met (also at half the step) |", "|---|---|---|---|---|---|---|"]
    configs = _labels()
    rows = [r for r in rows if "lost_legs" in r]  # searches only (not the bench, profile or variants)
    for lost in SCENARIOS:
        paper = _paper_fitness(rows, lost, table2)
        for part, cfg in configs:
            got = [r for r in rows if r["part"] == part and tuple(r["lost_legs"]) == lost]
            if not got or not any(r["part"].startswith("alt_") and tuple(r["lost_legs"]) == lost for r in rows):
                continue
            pf = [paper[r["seed"]] for r in got if r["seed"] in paper]
            wins = sum(r["fitness"] >= paper[r["seed"]] for r in got if r["seed"] in paper)
            s = cfg["search"]
            steps = statistics.median(r["sim_steps"] for r in got)
            out.append(f"| {_name(lost)} | `{json.dumps(cfg)}` | {s['population'] * (s['generations'] + 1)} "
                       f"({steps / 1e6:.2f} M) | "
                       f"{_spread([r['fitness'] for r in got], '{:.2f}')} ({len(got)}) | "
                       f"{_spread(pf, '{:.2f}')} ({len(pf)}) | {wins} of {len(pf)} | "
                       f"{sum(r['target_met'] for r in got)} ({sum(bool(r['half_step_met']) for r in got)}) of "
                       f"{len(got)} |")
    return out + [""]


def check_markdown(rows: list[dict]) -> list[str]:
    same = sum(bool(r["identical_to_documented"]) for r in rows)
    saved = sum(r["cut_steps_saved"] for r in rows) / max(1, sum(r["sim_steps"] + r["cut_steps_saved"] for r in rows))
    out = [f"Cut walks on every documented damage: the nominal answers of docs/recovery_robust_w20.json (DE 12 x 12, "
           f"1 ms, weights [1, 20, 10, 100, 100], every feasible 1- and 2-leg loss) searched again with "
           f"`search.cut_walks`: {same} of {len(rows)} answers are the documented ones bit for bit; the cut walks "
           f"saved {100 * saved:.1f} % of the steps.", "",
           "| damage | same answer | steps | steps saved | walks cut |", "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {_name(r['lost_legs'])} | {'yes' if r['identical_to_documented'] else '**no**'} | "
                   f"{r['sim_steps']:,} | {r['cut_steps_saved']:,} | {r.get('walks_cut', '-')} |")
    return out + [""]


def _close(a: float | None, b: float) -> bool:
    return a is not None and math.isclose(a, b, rel_tol=1e-9)


def control_markdown(rows: list[dict]) -> list[str]:
    """The random-search control with cut walks against full walks, run by run."""
    out = [f"The random-search control with cut walks (`controls.cut_walks`, on by default): the control of the "
           f"paper-size job (30 candidates x 61 generations on its own stream of the job's seed) run on the same job "
           f"with cut walks, then with full walks. {sum(r['identical'] for r in rows)} of {len(rows)} have the same "
           f"best (parameters and F) bit for bit. Table II's F: the control's F in docs/table2.json for that seed. "
           f"{sum(_close(r['documented_fitness'], r['cut']['fitness']) for r in rows)} of "
           f"{sum(r['documented_fitness'] is not None for r in rows)} agree with the cut control's to 1e-9 (relative) "
           f"and differ from the 12th digit on: numpy's AVX-512 math kernels on this host round the walk's metrics "
           f"differently (re-scored with them switched off, `NPY_DISABLE_CPU_FEATURES=\"AVX512_ICL X86_V4\"`, "
           f"these answers give Table II's F bit for bit). The rows that differ more were run before the control got "
           f"its own seed stream (commit 7caa61f).", "",
           "| damage | seed | same best | F | steps cut / full | walks cut | wall cut / full (s) | load | "
           "Table II's F |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        doc = r["documented_fitness"]
        cut, full = r["cut"], r["full"]
        out.append(f"| {_name(r['lost_legs'])} | {r['seed']} | {'yes' if r['identical'] else '**no**'} | "
                   f"{cut['fitness']:.2f} | {cut['sim_steps']:,} / {full['sim_steps']:,} | {cut['walks_cut']} | "
                   f"{cut['wall_s']:.0f} / {full['wall_s']:.0f} | {r['load']:.1f} | "
                   f"{'-' if doc is None else f'{doc:.2f}'} |")
    return out + [""]


def cap_markdown(rows: list[dict]) -> list[str]:
    from app.jobs.recovery.evaluate import CUT_SPEED_FACTOR

    top = max(r["max_ratio"] for r in rows)
    out = [f"Cut walks' speed cap: over {sum(r['walkers'] for r in rows)} uniform random walks that did not fall, the "
           f"fastest mean forward speed over the rest of a walk (from any chunk's end) was {top:.2f} times the gait's "
           f"nominal speed (step length per period); the rule caps it at {CUT_SPEED_FACTOR:g} times.", "",
           "| damage | walks (of candidates) | largest ratio | 99th percentile |", "|---|---|---|---|"]
    out += [f"| {_name(r['lost_legs'])} | {r['walkers']} ({r['candidates']}) | {r['max_ratio']:.2f} | "
            f"{r['p99_ratio']:.2f} |" for r in rows]
    return out + [""]


def runs_markdown(rows: list[dict]) -> list[str]:
    out = ["| part | damage | seed | F | target met (half step) | stop | generations | evaluations | steps | steps "
           "saved by cut walks | time to target (s) | wall (s) | load | host |", "|---" * 14 + "|"]
    for r in sorted(rows, key=lambda r: (r["part"], SCENARIOS.index(tuple(r["lost_legs"]))
                                         if tuple(r["lost_legs"]) in SCENARIOS else 9, r["seed"])):
        ttt = r.get("time_to_target_s")
        same = r.get("identical_to_documented")
        out.append(f"| {r['part']} | {_name(r['lost_legs'])} | {r['seed']} | {r['fitness']:.2f}"
                   f"{'' if same is None else (' (= docs)' if same else ' (**differs from docs**)')} | "
                   f"{'yes' if r['target_met'] else 'no'} ({'yes' if r['half_step_met'] else 'no'}) | "
                   f"{r['search']['stop_reason']} | {r['search']['generations_run']} | {r['evaluations']} | "
                   f"{r['sim_steps']:,} | {r['cut_steps_saved']:,} | {'-' if ttt is None else f'{ttt:.1f}'} | "
                   f"{r['wall_s']:.0f} | {r['load']:.1f} | {_host(r)} |")
    return out + [""]


def _host(row: dict) -> str:
    """The CPU a run ran on, where it was recorded (wall times differ between hosts)."""
    m = row.get("machine")
    return "not recorded" if m is None else machine_text(m, cores=False)


def _paper_by_seed(rows: list[dict], lost, table2: list[dict], own: Callable[[dict], Any],
                   documented: Callable[[dict], Any]) -> dict[int, Any]:
    """A value of the paper DE's answer per seed: ``own`` of this page's runs, else
    ``documented`` of docs/table2.json's (full walks; None: not there); rows that are not
    searches (no damage) are passed over."""
    rows = [r for r in rows if tuple(r.get("lost_legs", ())) == tuple(lost)]
    out = {r["seed"]: own(r) for r in rows if r["part"] == "paper"}
    for seed in {r["seed"] for r in rows} - set(out):
        doc = _documented(lost, seed, table2)
        value = None if doc is None else documented(doc)
        if value is not None:
            out[seed] = value
    return out


def _paper_fitness(rows: list[dict], lost, table2: list[dict]) -> dict[int, float]:
    """The paper DE's final F per seed."""
    return _paper_by_seed(rows, lost, table2, lambda r: r["fitness"], lambda d: d["best_fitness"])


def _paper_half_step(rows: list[dict], lost, table2: list[dict]) -> dict[int, bool]:
    """Whether the paper DE's answer meets the target at half the step, per seed (Table II's
    rows: their robustness case dt_half)."""
    def documented(d: dict) -> bool | None:
        case = (d.get("robustness") or {}).get("cases", {}).get("dt_half")
        return None if case is None else bool(case["target_met"])

    return _paper_by_seed(rows, lost, table2, lambda r: bool(r["half_step_met"]), documented)


def _at_budget(rows: list[dict], lost, eq: list[dict]) -> list[float]:
    """The paper DE's best F (its runs' history) once it had simulated as many steps as the
    equal-quality search of the same seed (its walks are all full: steps per walk from its
    own totals, the steps its cut walks saved included)."""
    out = []
    for r in eq:
        paper = next((p for p in rows if p["part"] == "paper" and tuple(p["lost_legs"]) == lost
                      and p["seed"] == r["seed"]), None)
        if paper is not None:
            walks = r["sim_steps"] * paper["evaluations"] / (paper["sim_steps"] + paper["cut_steps_saved"])
            out.append(max((b for _, b, n in paper["curve"] if n <= walks), default=float("nan")))
    return out


def _walks_to(run: dict, f: float) -> str:
    """How many walks ``run`` had evaluated when its best first reached ``f`` (its history),
    with the share of its whole budget, or "not reached"."""
    hit = next((n for _, b, n in run["curve"] if b >= f), None)
    return "not reached" if hit is None else f"{hit:,} ({100 * hit / run['evaluations']:.0f} %)"


def summary_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage: the paper DE's F against the equal-quality configuration's on the same
    seeds, and the fast preset's time to the target, in steps (machine-independent) and
    seconds (this machine, at its load)."""
    out = ["| damage | paper DE F, median [range] (seeds) | equal-quality F | equal >= paper, same seed | "
           "paper DE F after as many steps as the equal-quality search | "
           "equal-quality answers meeting the target (also at half the step) | equal-quality steps / paper DE steps | "
           "equal-quality run, whole budget (s) | equal-quality walks to the same seed's paper DE F | "
           "fast preset: steps to the target | fast preset: time to the target (s) | fast preset: met at half the "
           "step |", "|---" * 12 + "|"]
    for lost in SCENARIOS:
        eq = [r for r in rows if r["part"] == "equal" and tuple(r["lost_legs"]) == lost]
        fast = [r for r in rows if r["part"] == "fast" and tuple(r["lost_legs"]) == lost]
        paper = _paper_fitness(rows, lost, table2)
        if not (eq or fast):
            continue
        same = _equal_with_paper(rows, lost, table2)
        wins, pairs = sum(r["fitness"] >= f for r, f in same), len(same)
        ps = [r["sim_steps"] + r["cut_steps_saved"] for r in rows if r["part"] == "paper" and tuple(r["lost_legs"]) == lost]
        ratio = f"{statistics.median(r['sim_steps'] for r in eq) / statistics.median(ps):.2f}" if ps and eq else "-"
        met = f"{sum(r['target_met'] for r in eq)} ({sum(bool(r['half_step_met']) for r in eq)}) of {len(eq)}"
        ttt = [r["time_to_target_s"] for r in fast if r["time_to_target_s"] is not None]
        early = _at_budget(rows, lost, eq)
        reach = ", ".join(_walks_to(r, paper[r["seed"]]) for r in eq if r["seed"] in paper) or "-"
        out.append(f"| {_name(lost)} | {_spread(list(paper.values()), '{:.2f}')} ({len(paper)}) | "
                   f"{_spread([r['fitness'] for r in eq], '{:.2f}')} ({len(eq)}) | {wins} of {pairs} | "
                   f"{_spread(early, '{:.2f}')} ({len(early)}) | {met} | {ratio} | "
                   f"{_spread([r['wall_s'] for r in eq], '{:.0f}')} at load {_spread([r['load'] for r in eq])} | "
                   f"{reach} | {_spread([r['sim_steps'] for r in fast], '{:,.0f}')} | {_spread(ttt)} | "
                   f"{sum(bool(r['half_step_met']) for r in fast)} of {len(fast)} |")
    return out + [""]


def _equal_with_paper(rows: list[dict], lost, table2: list[dict]) -> list[tuple[dict, float]]:
    """The equal-quality runs on ``lost`` whose seed has a paper DE F (``_paper_fitness``),
    each with that F, by seed."""
    paper = _paper_fitness(rows, lost, table2)
    eq = [r for r in rows if r["part"] == "equal" and tuple(r["lost_legs"]) == tuple(lost) and r["seed"] in paper]
    return [(r, paper[r["seed"]]) for r in sorted(eq, key=lambda r: r["seed"])]


def paired_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage: the equal-quality configuration's final F against the paper DE's, paired
    by seed (app/jobs/stats.py: mean difference, its interval, Wilcoxon's test, the verdict),
    beside the medians the issue's rule compares: a median at least the paper DE's on a
    handful of seeds is not a difference shown, nor one below it a loss shown."""
    from app.jobs import stats

    out = []
    for lost in SCENARIOS:
        pairs = _equal_with_paper(rows, lost, table2)
        if len(pairs) < 2:
            continue
        a, b = [r["fitness"] for r, _ in pairs], [f for _, f in pairs]
        verdict = "reaches" if statistics.median(a) >= statistics.median(b) else "does not reach"
        r = stats.paired(a, b, names=("equal quality", "paper DE"))
        out.append(f"- {_name(lost)}: median F {statistics.median(a):.2f} against {statistics.median(b):.2f} "
                   f"({verdict} the paper DE's); equal quality minus paper DE, paired by seed: "
                   f"{stats.paired_text(r)}.")
    if not out:
        return []
    return ["The same comparison as a paired test on the seeds both have run (a verdict other than \"not shown\" needs "
            "the interval and the test to agree):", ""] + out + ["", stats.PAIRED_NOTE, ""]


# search.short_walks as tried: F of the short walk carried to the full walk's length, then
# the same without that (the short walk's own F); its controls on the same seeds: CMA-ES 12 with
# full walks for as many steps, and for 82 generations (more steps)
# (part labels as by_config gives them)
SHORT_ROWS = {"short walks": "equal", "short walks, own F": "alt_cmaes_12x83_short5_raw"}
SAME_STEPS, MORE_STEPS = "alt_cmaes_12x60", "alt_cmaes_12x82"


def _runs_of(rows: list[dict], part: str, lost) -> dict[int, dict]:
    """The runs labelled ``part`` (by_config: by the configuration they ran) on ``lost``, by seed."""
    return {r["seed"]: r for r in rows if r["part"] == part and tuple(r["lost_legs"]) == tuple(lost)}


def short_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """search.short_walks (SHORT_ROWS) against its controls on the same seeds: CMA-ES 12 with
    full walks for as many steps (SAME_STEPS) and for more (MORE_STEPS), and the paper DE;
    medians, then paired by seed."""
    from app.jobs import stats

    rows = [r for r in rows if "lost_legs" in r]
    tried = [name for name, cfg in SHORT_ROWS.items() if any(_runs_of(rows, cfg, lost) for lost in SCENARIOS)]
    if not tried:
        return []
    sw = EQUAL["search"]
    more = ALTERNATIVES[MORE_STEPS.removeprefix("alt_")]["search"]
    out = ["## Short walks in the first generations", "",
           "`search.short_walks` (CMA-ES only): the first generations walk for less time and only steer the search. "
           "Their F ranks the candidates, which is all CMA-ES's update uses, and is told as provisional: it never "
           "becomes the answer, and the stop rules pass over it. The answer is the best of the full-walk generations "
           "after them, judged at the default step and at half of it. With `extrapolate` (the default) the short "
           "walk's forward, lateral and yaw displacements are carried to the full walk's length as rates before F, "
           "so that a drift weighs as it would over the full walk; without it, F is the short walk's own. Tried: "
           f"{sw['short_walks']['generations']} generations of {sw['short_walks']['walk_s']:g} s walks, then "
           f"{sw['generations'] + 1 - sw['short_walks']['generations']} of full 10 s walks, CMA-ES 12 (this page's "
           "equal-quality configuration): the steps of CMA-ES 12 x 60 with full walks, its control at equal steps. "
           f"CMA-ES 12 x {more['generations']} with full walks spends more (the steps column). Same seeds in every "
           "column of a row; the paper DE's F and its answers at half the step as in the tables above (else "
           "docs/table2.json's robustness case dt_half).", "",
           f"| damage | configuration | seeds | F | CMA-ES 12 x 60, full walks (same steps) | CMA-ES 12 x "
           f"{more['generations']}, full walks | paper DE | steps: this / 12 x 60 / 12 x {more['generations']} | "
           "whole run (s) | target met (also at half the step) | paper DE: met at half the step |",
           "|---" * 11 + "|"]
    lines = []
    for lost in SCENARIOS:
        same, bigger, paper = _runs_of(rows, SAME_STEPS, lost), _runs_of(rows, MORE_STEPS, lost), _paper_fitness(
            rows, lost, table2)
        half = _paper_half_step(rows, lost, table2)
        for name in tried:
            short = _runs_of(rows, SHORT_ROWS[name], lost)
            seeds = sorted(set(short) & set(same) & set(paper))
            if not seeds:
                continue
            eq = [bigger[k]["fitness"] for k in seeds if k in bigger]
            steps = [statistics.median(r[k]["sim_steps"] for k in seeds) if all(k in r for k in seeds) else None
                     for r in (short, same, bigger)]
            out.append(f"| {_name(lost)} | {name} | {len(seeds)} | "
                       f"{_spread([short[k]['fitness'] for k in seeds], '{:.2f}')} | "
                       f"{_spread([same[k]['fitness'] for k in seeds], '{:.2f}')} | "
                       f"{_spread(eq, '{:.2f}') + ('' if len(eq) in (0, len(seeds)) else f' ({len(eq)})')} | "
                       f"{_spread([paper[k] for k in seeds], '{:.2f}')} | "
                       f"{' / '.join('-' if v is None else f'{v / 1e6:.2f} M' for v in steps)} | "
                       f"{_spread([short[k]['wall_s'] for k in seeds], '{:.0f}')} | "
                       f"{sum(short[k]['target_met'] for k in seeds)} "
                       f"({sum(bool(short[k]['half_step_met']) for k in seeds)}) of {len(seeds)} | "
                       f"{sum(half[k] for k in seeds if k in half)} of {sum(k in half for k in seeds)} |")
            a = [short[k]["fitness"] for k in seeds]
            for control, b in (("CMA-ES 12 x 60 with full walks", [same[k]["fitness"] for k in seeds]),
                               ("the paper DE", [paper[k] for k in seeds])):
                r = stats.paired(a, b, names=(name, control))
                lines.append(f"- {_name(lost)}: {name} minus {control}, paired by seed: {stats.paired_text(r)}.")
    if not lines:  # no seed has a same-steps run and a paper DE F beside the short walks
        return []
    return out + ["", "Paired by seed (the note above says how to read a verdict):", ""] + lines + [""]


# The answers a job's robustness block would judge, for the short walks against their controls:
# each set's answers (the seeds all three have) under every named case and on the held-out
# random models of their seed, so that "equal quality" covers the perturbed robot too.
PERTURBED_SETS = {"short walks": "equal", "CMA-ES 12 x 60, full walks (same steps)": SAME_STEPS, "paper DE": "paper"}


def _answers_of(rows: list[dict], lost, table2: list[dict]) -> dict[str, dict[int, dict]]:
    """PERTURBED_SETS' answers (their parameters) on ``lost``, by seed; the paper DE's from
    this page's runs, else Table II's (``rows`` labelled by by_config)."""
    out = {name: {k: r["params"] for k, r in _runs_of(rows, part, lost).items()}
           for name, part in PERTURBED_SETS.items() if part != "paper"}
    return out | {"paper DE": _paper_by_seed(rows, lost, table2, lambda r: r["params"], lambda d: d.get("best_params"))}


def perturbed_rows(rows: list[dict], table2: list[dict], damages, done: set):
    """A row per damage and seed not in ``done`` (yielded as each is done): the answers of
    PERTURBED_SETS for that seed re-walked under every named case (one batched rollout per set
    and damage) and on the seed's held-out random models (one rollout per seed), judged by
    the target, as a job's robustness block judges its answer."""
    for lost in damages:
        answers = _answers_of(by_config(rows), lost, table2)
        seeds = sorted(set.intersection(*(set(a) for a in answers.values())) - {k for d, k in done if d == tuple(lost)})
        if not seeds:
            continue
        job = set_up(RecoverySpec(damage={"lost_legs": list(lost)}))
        walk_s, n = job.spec.sim.duration_s, job.spec.robustness.held_out
        try:
            judged = {}
            for name, a in answers.items():
                x = np.array([list(a[k].values()) for k in seeds])
                cases = job.rob_ev.evaluate_all(x).metrics
                judged[name] = [[bool(target_met({key: v[i, c] for key, v in cases.items()}, walk_s))
                                 for c in range(len(job.cases))] for i in range(len(seeds))]
            for i, seed in enumerate(seeds):
                x = np.array([list(answers[name][seed].values()) for name in answers])
                _, r = held_out_walks(job.mspec, job.robot, job.seq, job.ev.cfg, x, seed, n)
                held = [sum(bool(target_met({key: v[j, k] for key, v in r.metrics.items()}, walk_s)) for k in range(n))
                        for j in range(len(answers))]
                yield {"part": "perturbed", "lost_legs": list(lost), "seed": seed, "held_out_n": n,
                       "cases": [c.name for c in job.cases], "labels": [c.label for c in job.cases],
                       "sets": {name: {"cases_met": judged[name][i], "held_out_met": held[j]}
                                for j, name in enumerate(answers)},
                       "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}
        finally:
            job.close()


def perturbed_markdown(rows: list[dict]) -> list[str]:
    """The answers of PERTURBED_SETS under each named case and on the held-out models, per
    damage (the same seeds in every set), then the short walks paired by seed against each
    control on the models met (named cases and held-out together)."""
    from app.jobs import stats

    rows = [r for r in rows if r["part"] == "perturbed"]
    if not rows:
        return []
    labels, n = rows[0]["labels"], rows[0]["held_out_n"]
    out = ["### The answers on the perturbed robot", "",
           "Each set's answers for the same seeds, re-walked as a job's robustness block walks its answer: under "
           f"every named case and on the {n} held-out random models of the seed (the held-out stream of the job's "
           "seed: the three answers of a seed face the same models), judged by the target. The short walks search "
           "the nominal model only, as do both controls.", "",
           "| damage | answers | seeds | " + " | ".join(labels) + f" | held-out models met (of {n} per seed) |",
           "|---" * (4 + len(labels)) + "|"]
    lines, worse = [], []
    for lost in SCENARIOS:
        got = sorted((r for r in rows if tuple(r["lost_legs"]) == lost), key=lambda r: r["seed"])
        if not got:
            continue
        for name in PERTURBED_SETS:
            met = [sum(r["sets"][name]["cases_met"][c] for r in got) for c in range(len(labels))]
            held = [r["sets"][name]["held_out_met"] for r in got]
            out.append(f"| {_name(lost)} | {name} | {len(got)} | " + " | ".join(f"{m} of {len(got)}" for m in met)
                       + f" | {sum(held)} of {n * len(got)} (median {statistics.median(held):g}) |")
        models = {name: [sum(r["sets"][name]["cases_met"]) + r["sets"][name]["held_out_met"] for r in got]
                  for name in PERTURBED_SETS}
        for control in list(PERTURBED_SETS)[1:]:
            res = stats.paired(models["short walks"], models[control], names=("short walks", control))
            worse += [f"{_name(lost)} (against {control})"] if res["shown"] == "control" else []
            lines.append(f"- {_name(lost)}: models met (of {len(labels) + n}), short walks minus {control}, paired "
                         f"by seed: {stats.paired_text(res)}.")
    verdict = ("Equal quality above is judged on the nominal model, as the issue's rule asks. On the perturbed robot "
               "the short walks' answers are shown less robust on " + "; ".join(worse) + ", and no difference is "
               "shown elsewhere." if worse else "On the perturbed robot no difference from either control is shown.")
    return out + ["", "Paired by seed (the note above says how to read a verdict):", ""] + lines + ["", verdict, ""]


def _frac(num: float, den: float) -> str:
    return f"{100 * num / den:.1f} %" if den else "-"


def gains_markdown(rows: list[dict], table2: list[dict] | None = None) -> list[str]:
    """The table of changes: what each saves, from the runs on this page."""
    by = {p: [r for r in rows if r["part"] == p]
          for p in ("throughput", "check", "paper", "fast", "equal", "pairs", "control")}
    out = ["| change | default job | measured here | command |", "|---|---|---|---|"]
    for r in by["pairs"][-1:]:
        names = [n for n in STEP_SETTINGS if n in r["damages"][0]["us_per_step"]]  # an older row has fewer
        for prev, name in zip(names, names[1:]):
            ups = ", ".join(f"{_name(d['lost_legs'])} {d['us_per_step'][prev]:.1f} -> {d['us_per_step'][name]:.1f} us "
                            f"({d['us_per_step'][prev] / d['us_per_step'][name]:.2f}x)" for d in r["damages"])
            out.append(f"| {STEP_TEXT[name]} | yes | single-thread CPU per step {ups} (load {r['load']:.1f}); the "
                       f"{r['answers']} documented answers "
                       f"{'bit-identical to before' if r['identical'][name] else '**not** identical to before'} | "
                       f"`gaitmend reproduce recovery-speed --parts pairs` |")
    for r in by["throughput"][-1:]:
        out.append(f"| evaluator: each chunk's controls from one gait period, the rollout's output buffers kept "
                   f"(same numbers bit for bit) | yes | through the evaluator {r['evaluator_steps_per_s']:,.0f} "
                   f"steps/s against {r['raw_steps_per_s']:,.0f} raw: ratio {r['ratio']:.2f} (load {r['load']:.1f}) | "
                   f"`gaitmend bench --kind recovery --json` (ratio) |")
    cut = by["paper"] + by["check"]
    if cut:
        same = sum(bool(r["identical_to_documented"]) for r in cut if r["identical_to_documented"] is not None)
        known = sum(r["identical_to_documented"] is not None for r in cut)
        saved = sum(r["cut_steps_saved"] for r in cut)
        total = sum(r["sim_steps"] + r["cut_steps_saved"] for r in cut)
        out.append(f"| `search.cut_walks`: a trial's walk ends once it cannot reach its parent's F | no (fast "
                   f"preset) | {_frac(saved, total)} of the steps over {len(cut)} searches; {same} of {known} answers "
                   f"the documented full-walk ones bit for bit | `gaitmend reproduce recovery-speed --parts "
                   f"check,paper` |")
    ctl = by["control"]
    if ctl:
        cs, fs = (sum(r[k]["sim_steps"] for r in ctl) for k in ("cut", "full"))
        cw, fw = (sum(r[k]["wall_s"] for r in ctl) for k in ("cut", "full"))
        out.append(f"| `controls.cut_walks`: the random-search control's walk ends once it cannot beat the control's "
                   f"best so far | yes | {sum(r['identical'] for r in ctl)} of {len(ctl)} controls (30 x 60) the same "
                   f"best as with full walks, bit for bit; {cs:,} steps against {fs:,} ({fs / cs:.1f}x fewer), "
                   f"{cw:.0f} s against {fw:.0f} s in all | `gaitmend reproduce recovery-speed --parts control` |")
    if by["fast"] and by["paper"]:
        steps = statistics.median(r["sim_steps"] for r in by["fast"])
        paper = statistics.median(r["sim_steps"] + r["cut_steps_saved"] for r in by["paper"])
        out.append(f"| `stop.at_target` (fast preset): stop once the best meets the target, confirmed at half the "
                   f"step | no (fast preset) | median {steps:,.0f} steps to the target over {len(by['fast'])} runs "
                   f"against {paper:,.0f} for the paper's whole budget ({paper / steps:.0f}x fewer) | "
                   f"`gaitmend reproduce recovery-speed --parts fast` |")
    # F on the same seeds on both sides: the paper DE's runs here, else Table II's for the seed
    same = _equal_with_paper(rows, (1, 6), table2 or [])
    eq = [r for r in by["equal"] if r["lost_legs"] == [1, 6]]
    paper = [r for r in by["paper"] if r["lost_legs"] == [1, 6]]
    if paper and same:
        es = statistics.median(r["sim_steps"] for r in eq)
        ps = statistics.median(r["sim_steps"] + r["cut_steps_saved"] for r in paper)
        ef = statistics.median(r["fitness"] for r, _ in same)
        pf = statistics.median(f for _, f in same)
        out.append(f"| equal-quality configuration `{json.dumps(EQUAL)}` | no (a spec) | legs 1 & 6, {len(eq)} seeds: "
                   f"median {es:,.0f} steps against the paper DE's {ps:,.0f} ({ps / es:.1f}x fewer), median F "
                   f"{ef:.2f} against {pf:.2f} on the same {len(same)} seeds: "
                   f"{'equal' if ef >= pf else '**not** equal'} quality on the nominal model (other damages and the "
                   "perturbed robot below) | "
                   f"`gaitmend reproduce recovery-speed --parts equal,paper` |")
    return out + [""]


STEP_TEXT = {"explicit contact pairs": "explicit contact pairs: the robot-floor pairs declared once "
                                      "(app/robots/contacts.py) instead of found by MuJoCo's broad phase every step",
             "explicit contact pairs, no island discovery (now)": "no constraint-island discovery (the robot is one "
                                                                  "island on a static floor)",
             "one fall-contact sensor": "the fall test's contacts from one sensor (every contact less the feet's, "
                                        "app/robots/hexapod.py) instead of one sensor per watched body"}
TITLE = "# Recovery speed (issue 22)"
JSON, TABLE2_JSON = "docs/recovery_speed.json", "docs/table2.json"
SECTION, COMMAND = "recovery-speed", "gaitmend reproduce recovery-speed"
INTRO = """Measured by `gaitmend reproduce recovery-speed` (this page and recovery_speed.json; every
row is a run of this code, written as it finished). The machine was shared: wall times
and steps/s carry the load (1-minute load average on its 2 cores) they were measured at;
simulated steps do not depend on the machine, so the gains are stated in steps first.
`gaitmend bench --kind recovery --json` measures the issue's figures on one machine in one
go. Paper DE = DE 30 x 60, 10 s walks, 1 ms (here with `search.cut_walks`; for seeds the
docs hold, its answer is compared with the full-walk answer in docs/table2.json). Fast =
`{"preset": "fast"}`. Equal quality = the configuration below. Every search's answer is
also re-run at half the step (the robustness case dt_half); the searches here are not re-run
under perturbed friction or masses (a job's robustness block does that: docs/recovery_robust.md),
so this page claims speed and F at the default step, not robustness. The step changes
(contact pairs, islands, the fall sensor) are checked bit for bit in every world a job
builds, the perturbed ones included (tests/robots/test_contacts.py).
"""

RULE = """## Cut walks: the rule

DE keeps a trial only if its F is at least its parent's (Eq. 10). After each 1 s chunk of a
trial's walk, F is bounded from above: the roll and pitch amplitudes so far (they only grow
as the walk goes on) in the denominator, the drift and yaw terms at their least (0), and
the forward displacement so far plus the rest of the walk at `CUT_SPEED_FACTOR` times the
gait's nominal speed (step length per period). Once that bound is below the parent's F,
the walk stops and the bound is told to DE in place of F: the parent stays, as it would
after the full walk. The answer is the full-walk DE's whenever the speed cap holds; the
history's mean, worst and generation_best skip the bounds (column `cut` counts them). The
drift and yaw cannot bound F this way (they can shrink again), so a walk that only drifts
is never cut: the gain is largest on rocking two-leg walks and near zero where the body
barely rocks (leg 4 lost).

The random-search control (`controls.cut_walks`, on by default) uses the same bound against
its best so far: a uniform draw never depends on F, and only a walk above the best so far
changes the control's answer, so its best is the full-walk control's whenever the cap
holds. Most random walks fall short of a good gait within seconds, so here the rule saves
far more than in DE, whose trials are near their parents.
"""


def bench_markdown(row: dict) -> list[str]:
    """The issue's targets as `gaitmend bench --kind recovery --json` measured them."""
    f, t = row["figures"], row["figures"].get("targets", {})
    eq = f["equal_quality"]
    peer = {n: p["ratio_to_ours"] for n, p in f["peers"].items()}
    yes = {True: "met", False: "**not met**"}
    cells = [
        ("raw rollout / through the evaluator (steps/s)", f"{f['raw_steps_per_s']:,.0f} / "
         f"{f['evaluator_steps_per_s']:,.0f}, ratio {f['ratio']:.2f}", ">= 0.9", yes[t.get("ratio_met", False)]),
        ("exact paper DE (30 x 60, full 10 s walks), legs 1 & 6", f"{f['paper_recovery_wall_s']:.1f} s, F "
         f"{f['paper']['fitness']:.2f}, target {'met' if f['paper']['target_met'] else 'not met'}", "<= 120 s",
         yes[t.get("paper_recovery_met", False)]),
        ("fast preset: time to the target, 4 damages x 3 seeds", f"median {f['time_to_target_median_s']:.1f} s "
         f"[{f['fast']['time_to_target_s']['min']:.1f}, {f['fast']['time_to_target_s']['max']:.1f}], {f['fast']['reached']} "
         f"reached, all met at half the step: {f['fast']['all_met_at_half_step']}", "<= 20 s",
         yes[t.get("time_to_target_met", False)]),
        ("peers' time to the target over ours (legs 1 & 6, 3 seeds)", "; ".join(
            f"{n}: median {p['median']:.2f} [{p['min']:.2f}, {p['max']:.2f}]" for n, p in peer.items() if p), "-", "-"),
        (f"equal quality (legs 1 & 6, seed 0; `{json.dumps(eq['config'])}`): the paper DE's F and the target",
         f"F {eq['fitness']:.2f} against "
         f"{eq['paper_fitness']:.2f} after {eq['wall_s']:.1f} s: {'reached' if eq['reached'] else 'not reached'}",
         "<= 60 s", yes[t.get("equal_quality_met", False)]),
        ("the bench itself", f"{f['bench_wall_s']:.0f} s", "< 240 s", yes[t.get("bench_met", False)]),
    ]
    host = machine_text(row["machine"]) if "machine" in row else f"{row['cores']} cores (the CPU not recorded)"
    out = [f"`gaitmend bench --kind recovery --json` on {host}, at load {row['load_before']:.1f} before and "
           f"{row['load_after']:.1f} after (the bench's own two threads count in the load):", "",
           "| figure | measured | issue 22's target | |", "|---|---|---|---|"]
    return out + [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in cells] + [""]


def speed_markdown(rows: list[dict], docs: Path = Path("docs")) -> str:
    """The page's generated text from the runs and Table II's rows under ``docs``."""
    return render_markdown(rows, _table2_rows(docs))


def render(datas: list) -> str:
    """docs/recovery_speed.md's generated section, from docs/recovery_speed.json and docs/table2.json."""
    rows, table2 = datas
    if rows is None:
        return missing(JSON, COMMAND)
    return render_markdown(rows, table2 or [])


def page(md: str) -> str:
    """The page the command writes: its title, then ``md`` inside the generated-section marker,
    so `gaitmend docs` and the docs-from-data test re-render it from the JSON."""
    return f"{TITLE}\n\n{marked(SECTION, COMMAND, md)}\n"


def render_markdown(rows: list[dict], table2: list[dict]) -> str:
    """Everything below the title, from the runs (docs/recovery_speed.json) and Table II's rows
    (docs/table2.json, the paper DE's F where this page has no run of it): nothing is measured here."""
    rows = by_config(rows)
    runs = [r for r in rows if r["part"] in ("paper", "fast", "equal") or r["part"].startswith("alt_")]
    out = [INTRO]
    benches = [r for r in rows if r["part"] == "bench"]
    if benches:
        out += ["## The issue's targets", "", "Every run of the bench, oldest first (the equal-quality configuration "
                "is the one of its time). Runs differ by the machine's load and by the host: sessions run on hosts "
                "sold under one CPU name but of different speed, so each run's raw rollout steps/s (its first row: "
                "the same workload every time) says how fast its host was; the runs before the CPU's family and "
                "model were recorded name only their cores.", ""]
        for bench in benches:
            out += bench_markdown(bench)
    out += ["## Changes and their gains", ""] + gains_markdown(rows, table2)
    scaling = [r for r in rows if r["part"] == "scaling"]
    if scaling:
        paper = [r["sim_steps"] + r["cut_steps_saved"] for r in rows if r["part"] == "paper"]
        out += scaling_markdown(scaling[-1], statistics.median(paper) if paper else None,
                                benches[-1]["figures"]["paper_recovery_wall_s"] if benches else None)
    out += ["## Equal quality and time to the target", "",
            "Paper DE F: the runs below, else docs/table2.json's full-walk run for that seed. Steps count every walk "
            "the search simulated (a cut walk's steps up to its cut); the paper DE's include the steps its cut walks "
            "saved, so they are the full-walk search's. Wall times are of the hosts the runs ran on, which differ in "
            "speed (the runs' table at the end names the host where the run recorded it).", ""] + summary_markdown(
                runs, table2) + paired_markdown(runs, table2)
    out += [RULE]
    for part, render in (("cap", cap_markdown), ("check", check_markdown), ("control", control_markdown)):
        got = [r for r in rows if r["part"] == part]
        if got:
            out += render(got)
    out += short_markdown(rows, table2) + perturbed_markdown(rows)
    out += ["## Tried and rejected", ""]
    prof = next((r for r in rows if r["part"] == "profile"), None)
    if prof is not None:
        out += profile_markdown(prof)
    var = [r for r in rows if r["part"] == "variants"]
    if var:
        out += variants_markdown(var)
    coarse = [r for r in rows if r["part"] == "coarse"]
    if coarse:
        out += coarse_markdown(coarse)
    if any(r["part"].startswith("alt_") for r in rows):
        out += alternatives_markdown(rows, table2)
    out += ["## Every search run", ""] + runs_markdown(runs)
    return "\n".join(out)

"""Where a simulation step's time goes and what the physics settings tried save (issue 22):
MuJoCo's timers per stage, the CPU time per step under each setting, the throughput with
more threads, and the speed cap of the cut walks."""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from app.jobs.base import MemoryContext
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.speed_configs import ONLY_SEARCH, PAPER, SCENARIOS, _uniform


STAGES = ("mjTIMER_STEP", "mjTIMER_POSITION", "mjTIMER_POS_KINEMATICS", "mjTIMER_POS_INERTIA",
          "mjTIMER_POS_COLLISION", "mjTIMER_COL_BROAD", "mjTIMER_COL_NARROW", "mjTIMER_POS_MAKE", "mjTIMER_VELOCITY",
          "mjTIMER_ACTUATION", "mjTIMER_CONSTRAINT", "mjTIMER_ADVANCE")


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
    from app.jobs.recovery.reproduce.documented_answers import answers_metrics, documented_answers
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
    from app.jobs.recovery.reproduce.documented_answers import answers_metrics, documented_answers
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


STEP_TEXT = {"explicit contact pairs": "explicit contact pairs: the robot-floor pairs declared once "
                                      "(app/robots/contacts.py) instead of found by MuJoCo's broad phase every step",
             "explicit contact pairs, no island discovery (now)": "no constraint-island discovery (the robot is one "
                                                                  "island on a static floor)",
             "one fall-contact sensor": "the fall test's contacts from one sensor (every contact less the feet's, "
                                        "app/robots/hexapod/__init__.py) instead of one sensor per watched body"}

"""The ``recovery`` job: gait-sequence planning + DE over leg-tip trajectories (paper 000).

``run`` is five steps over one state (``_Job``): ``set_up`` (the damaged robot, its gait
sequence, the search space and the evaluators), ``search`` (DE, then the random-search
control at the same budget), ``controls`` (the answer, the nominal tripod and the control's
best re-scored), ``robustness`` (the answer re-simulated under the standard cases) and
``summary``; ``record_traces`` keeps the two walks for the replay.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping

import mujoco
import numpy as np

from app.jobs.base import JobResult, RunContext
from app.jobs.evidence import ControlRow, PhaseContext, Phases, Robustness, control_seed
from app.jobs.loop import Generation, GoalCheck, SearchOutcome, run_search
from app.jobs.recovery import userrobot
from app.jobs.recovery.cases import CHOICE_STREAM, walking_cases
from app.jobs.recovery.closedloop import law_of
from app.jobs.recovery.evaluate import CUT_SPEED_FACTOR, Cutoff, GaitEvaluator, SimConfig
from app.jobs.recovery.export import upload_files
from app.jobs.recovery.metrics import basis_text, fitness, objective_terms, target_for, target_met
from app.jobs.recovery.randomised import RandomisedScorer
from app.jobs.recovery.robust import MultiModelEvaluator, case_models, held_out, robust_fitness
from app.jobs.recovery.sequences import GaitSequence, hexapod_neighbours, nominal_tripod, plan_hexapod
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.trajectory import bounds_of, param_names, search_box
from app.optim.registry import make_optimizer
from app.robots.catalog import ROBOTS, RobotEntry, get_robot
from app.robots.damage import Damage
from app.sim.perturb import Perturbation, draw_models, edit_model, random_models

# -- problem setup -------------------------------------------------------------------------

def functional_legs(spec: RecoverySpec) -> list[int]:
    return [l for l in range(1, 7) if l not in spec.damage.lost_legs]


def damage_spec(spec: RecoverySpec) -> Damage:
    """The built-in robot's damage in the robot layer's vocabulary: ``robot_damage`` as
    given by name, else the paper's leg numbers translated to the leg map's names."""
    return spec.robot_damage if spec.robot_damage is not None else spec.damage.named()


def search_bounds(spec: RecoverySpec, robot: RobotEntry) -> tuple[np.ndarray, np.ndarray]:
    """X_min / X_max in the layout of ``param_names``. y0 bounds of legs next to a lost
    leg move outward by ``neighbour_relaxation`` of their width on each side (Sec. III-B)."""
    lost = set(spec.damage.lost_legs)
    return bounds_of(spec.bounds, robot, functional_legs(spec), {n for l in lost for n in hexapod_neighbours(l)} - lost)



def nominal_params(robot: RobotEntry, legs: list[int]) -> np.ndarray:
    return np.array([robot.nominal_y0(l) for l in legs] + [robot.nominal_x0()] * len(legs)
                    + [robot.nominal_step_length, robot.nominal_step_height])


def sim_model(spec: RecoverySpec, robot: RobotEntry, pairs: bool = True, islands: bool = False,
              merged_fall: bool = True):
    """The damaged robot's spec and model at the spec's timestep (the bundle's robot.xml
    is the spec, so the timestep is set there, not only in the compiled model); ``pairs``,
    ``islands`` and ``merged_fall``: the step's settings of RobotEntry.model (the defaults
    are the fast ones; the others give the same numbers, slower)."""
    mspec, _ = robot.model(damage_spec(spec), pairs=pairs, islands=islands, merged_fall=merged_fall)
    mspec.option.timestep = spec.sim.timestep_s
    return mspec, mspec.compile()


def sim_config(spec: RecoverySpec, open_loop: bool = False) -> SimConfig:
    """The simulation settings of ``spec``; with ``open_loop``, without the closed-loop
    correction even if the spec asks for it (the answer's open-loop re-runs)."""
    law = None if open_loop else law_of(spec.control, spec.bounds.step_length_m
                                        or search_box(get_robot(spec.robot)).step_length)
    return SimConfig(duration_s=spec.sim.duration_s, settle_s=spec.sim.settle_s, period_s=spec.gait.period_s,
                     stance_height_m=spec.gait.stance_height_m, step_depth_m=spec.gait.step_depth_m, law=law)


def _scalars(metrics: Mapping[str, np.ndarray], k: int | None = None) -> dict:
    """One candidate's metrics as JSON scalars: the first row of (P,) arrays, or column
    ``k`` of the first row of (P, K) arrays (one column per model)."""
    return {key: (bool(x) if key == "fell" else float(x))
            for key, x in ((key, v[0] if k is None else v[0, k]) for key, v in metrics.items())}


def _params(names: list[str], x: np.ndarray) -> dict[str, float]:
    return {n: float(v) for n, v in zip(names, x)}


def _scored(ev: GaitEvaluator, x: np.ndarray, weights, units: str) -> dict:
    r = ev.evaluate(x)
    terms = {k: float(v[0]) for k, v in objective_terms(r.metrics, weights, units).items()}
    return {"metrics": _scalars(r.metrics), "fitness": float(fitness(r.metrics, weights, units)[0]), "terms": terms}


# -- the job ---------------------------------------------------------------------------------

class _Scorer:
    """Fitness of a population on the nominal model, or on several models (robust search).
    Returns (fitness (P,), nominal-model metrics (P,), simulated steps). It keeps the last
    population's metrics, so the search's goal can read the best's without a re-run."""

    # what a walk's end displacements scale with: a short walk's carried to the full walk as rates
    STRETCHED = ("y_f_m", "x_f_m", "yaw_f_deg")

    def __init__(self, spec: RecoverySpec, robot: RobotEntry, mspec, model, seq: GaitSequence, cfg: SimConfig,
                 stretch: float = 1.0):
        self.weights, self.units = spec.objective.weights, spec.objective.units
        self.stretch = stretch  # F of displacements times this (search.short_walks.extrapolate); metrics as walked
        self.robust = spec.robust
        self.models_per_candidate = spec.models_per_candidate
        self.cases = walking_cases(robot.geometry.total_mass, spec.robust.models) if spec.robust else []
        models = [model] + case_models(mspec, model, self.cases)
        self.ev = MultiModelEvaluator(robot, models, seq, cfg)
        self.period_s = cfg.period_s
        self.cut_walks = spec.search.cut_walks  # its history then has a "cut" column (one model only: generation)
        self.last: tuple[np.ndarray, dict[str, np.ndarray]] | None = None

    def cutoff(self, x: np.ndarray, thresholds: np.ndarray | None) -> Cutoff | None:
        """Early termination against ``thresholds`` (DE's parents, random search's best so
        far), on the nominal model only."""
        if thresholds is None or self.robust is not None:
            return None
        cap = CUT_SPEED_FACTOR * np.atleast_2d(x)[:, -2] / self.period_s  # step length per gait period
        return Cutoff(np.asarray(thresholds, dtype=float), cap, tuple(self.weights), self.units)

    def __call__(self, x: np.ndarray, thresholds: np.ndarray | None = None):
        cut = self.cutoff(x, thresholds)
        r = self.ev.evaluate_all(x) if cut is None else self.ev.evaluators[0].evaluate_all(x, cut)
        m = {k: v[:, 0] for k, v in r.metrics.items()}
        self.last = (np.atleast_2d(x).copy(), m)
        if self.robust is not None:
            f, _ = robust_fitness(r.metrics, self.weights, self.units, self.robust.aggregate)
            return f, m, r.sim_steps, None
        f = fitness(m if self.stretch == 1.0 else m | {k: m[k] * self.stretch for k in self.STRETCHED},
                    self.weights, self.units)
        return (f, m, r.sim_steps, None) if cut is None else (np.where(cut.cut, cut.bound, f), m, r.sim_steps, cut)

    def generation(self, x: np.ndarray, thresholds: np.ndarray | None = None, cuts: bool | None = None) -> Generation:
        """One generation of a search: fitness, falls, simulated steps (and walks cut short).
        ``cuts``: whether this search cuts walks against ``thresholds`` (default: the search's
        own setting, ``search.cut_walks``); its rows then have the cut columns."""
        cuts = (self.cut_walks if cuts is None else cuts) and self.robust is None
        f, m, steps, cut = self(x, thresholds if cuts else None)
        cols, totals = {"fell": int(np.sum(m["fell"]))}, {"sim_steps": steps}  # a walk cut short has not fallen
        if cuts:  # every row (generation 0 has no thresholds: nothing cut), so the history is one table
            cols["cut"] = 0 if cut is None else int(np.sum(cut.cut))
            totals["cut_steps_saved"] = 0 if cut is None else cut.saved_steps
        return Generation(f, cols, totals, evaluations=len(f) * self.models_per_candidate,
                          exact=None if cut is None else ~cut.cut)

    def metrics_of(self, x: np.ndarray) -> dict | None:
        """The nominal-model metrics of ``x`` if it was in the last population evaluated."""
        if self.last is None:
            return None
        rows = np.flatnonzero(np.all(self.last[0] == x, axis=1))
        return None if rows.size == 0 else _scalars({k: v[rows[:1]] for k, v in self.last[1].items()})

    def per_model(self, x: np.ndarray) -> list[dict]:
        r = self.ev.evaluate_all(x)
        _, f = robust_fitness(r.metrics, self.weights, self.units, self.robust.aggregate)
        names = ["nominal"] + [c.name for c in self.cases]
        return [{"name": n, "fitness": float(f[0, k]), "metrics": _scalars(r.metrics, k)} for k, n in enumerate(names)]

    def close(self):
        self.ev.close()


class _Goal:
    """The recovery target as the search's stop rule: the best so far meets it on the walk
    the search scored (re-run at the step if that walk is not at hand), then again at half
    the step. The confirmation is a real walk and counts as an evaluation."""

    def __init__(self, score: _Scorer, ev: GaitEvaluator, half_ev: GaitEvaluator):
        self.score, self.ev, self.half_ev = score, ev, half_ev

    def __call__(self, x: np.ndarray) -> GoalCheck:
        m, walk_s = self.score.metrics_of(x), self.ev.cfg.duration_s  # the target scales with the walk
        if m is not None and not target_met(m, walk_s):
            return GoalCheck(False)
        n, steps = 0, 0
        for ev in ([] if m is not None else [self.ev]) + [self.half_ev]:
            r = ev.evaluate(x)
            n, steps = n + 1, steps + r.sim_steps
            if not target_met(_scalars(r.metrics), walk_s):
                return GoalCheck(False, n, {"sim_steps": steps})
        return GoalCheck(True, n, {"sim_steps": steps})


@dataclasses.dataclass
class _Job:
    """What the steps share: the problem set up once, its evaluators (closed at the end),
    what each step found, and the tallies the steps add to."""

    spec: RecoverySpec
    robot: RobotEntry
    mspec: mujoco.MjSpec
    model: mujoco.MjModel
    legs: list[int]
    seq: GaitSequence
    lower: np.ndarray
    upper: np.ndarray
    names: list[str]
    score: _Scorer
    ev: GaitEvaluator  # the planned gait sequence on the nominal model
    base_ev: GaitEvaluator  # the nominal tripod
    cases: list[Perturbation]
    rob_ev: MultiModelEvaluator | None
    half_ev: GaitEvaluator | None = None  # the nominal model at half the step (the target's confirmation)
    short: _Scorer | None = None  # search.short_walks: the early generations' shorter walks
    searches: dict[str, SearchOutcome] = dataclasses.field(default_factory=dict)
    best: dict = dataclasses.field(default_factory=dict)
    baseline: dict = dataclasses.field(default_factory=dict)
    controls: list[dict] = dataclasses.field(default_factory=list)
    robustness: dict | None = None
    held_out: dict | None = None  # the answer on the held-out random models
    open_loop: dict | None = None  # closed loop: the answer again without the correction
    robust: dict | None = None
    population: tuple | None = None  # choice robust: DE's final population and its F
    choice: dict | None = None  # choice robust: what was chosen and why
    traces: dict = dataclasses.field(default_factory=dict)
    evaluations: int = 0
    sim_steps: int = 0
    wall_s: float = 0.0  # the searches' (summed over resumes), then the post-search steps'
    setup_s: float = 0.0

    @property
    def nominal_x(self) -> np.ndarray:
        return nominal_params(self.robot, self.legs)

    def close(self) -> None:
        for ev in (self.score, self.ev, self.base_ev, self.rob_ev, self.half_ev, self.short):
            if ev is not None:
                ev.close()


def set_up(spec: RecoverySpec) -> _Job:
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    legs = functional_legs(spec)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    cfg = sim_config(spec)
    lower, upper = search_bounds(spec, robot)
    cases = walking_cases(robot.geometry.total_mass, spec.robustness.cases)
    return _Job(spec=spec, robot=robot, mspec=mspec, model=model, legs=legs, seq=seq, lower=lower, upper=upper,
                names=param_names(legs), score=scorer(spec, robot, mspec, model, seq, cfg),
                ev=GaitEvaluator(robot, model, seq, cfg), base_ev=GaitEvaluator(robot, model, nominal_tripod(legs), cfg),
                cases=cases,
                rob_ev=MultiModelEvaluator(robot, case_models(mspec, model, cases), seq, cfg) if cases else None)


def scorer(spec: RecoverySpec, robot, mspec, model, seq, cfg) -> _Scorer | RandomisedScorer:
    """The search's fitness: on the nominal model (or the robust search's fixed models), or
    on each generation's draw of random models (``randomised``); any robot."""
    if spec.randomised:
        return RandomisedScorer(spec, robot, mspec, seq, cfg)
    return _Scorer(spec, robot, mspec, model, seq, cfg)


def phase_sizes(spec: RecoverySpec) -> dict[str, int]:
    """Each phase's share of the progress bar, in simulated walks."""
    s = spec.search
    per_search = spec.search_walks
    rnd = int(spec.controls.random_search)
    sizes = {"search": per_search, "random_search": rnd * per_search, "choice": spec.choice_walks, "final_scoring": 2,
             "random_search_scoring": rnd, "robustness": len(spec.robustness.cases),
             "held_out": spec.robustness.held_out, "traces": 2}
    if spec.control.mode == "closed_loop":
        sizes["open_loop"] = 1 + len(spec.robustness.cases) + spec.robustness.held_out
    return {name: n for name, n in sizes.items() if n}


def _half_step_evaluator(job: _Job) -> GaitEvaluator:
    return GaitEvaluator(job.robot, edit_model(job.model, Perturbation("half", "half step", timestep_scale=0.5)),
                         job.seq, job.ev.cfg)


def _short_scorer(job: _Job) -> _Scorer:
    """The nominal model's scorer with the walks of search.short_walks (the same robot,
    gait and settling; only the walk ends sooner), its displacements carried to the full
    walk when ``extrapolate``."""
    sw = job.spec.search.short_walks
    cfg = dataclasses.replace(job.ev.cfg, duration_s=sw.walk_s)
    stretch = job.spec.sim.duration_s / sw.walk_s if sw.extrapolate else 1.0
    return _Scorer(job.spec, job.robot, job.mspec, job.model, job.seq, cfg, stretch)


def search(job: _Job, phases: Phases) -> None:
    """The search, then (when asked) the uniform random search over the same bounds for as
    many generations as the search ran (fewer when a stop rule ended it early). With
    search.short_walks, the first generations walk for less time and are told to CMA-ES as
    provisional (they rank, they are not the answer)."""
    s, stop = job.spec.search, job.spec.stop
    opt = make_optimizer(s.optimizer, job.lower, job.upper, s.population, s.seed, cr=s.cr, f=s.f)
    if s.short_walks is not None:
        job.short = _short_scorer(job)
    walk = {"walk_s": job.spec.sim.duration_s} if s.short_walks is not None else {}  # every row, one table

    def evaluate(x: np.ndarray) -> Generation:  # with cut walks, DE's parents are its trials' thresholds
        if job.spec.randomised is not None:  # the generation's draw; DE's parents scored again on it
            return job.score.redrawn(opt, x)
        if job.short is not None and opt.generation < s.short_walks.generations:
            g = job.short.generation(x)
            return dataclasses.replace(g, columns=g.columns | {"walk_s": s.short_walks.walk_s}, provisional=True)
        g = job.score.generation(x, opt.selection_thresholds() if s.cut_walks else None)
        return dataclasses.replace(g, columns=g.columns | walk)

    goal = None
    if stop.at_target:
        job.half_ev = _half_step_evaluator(job)
        goal = _Goal(job.score, job.ev, job.half_ev)
    job.searches["search"] = run_search(opt, evaluate, s.generations, phases.context("search"), stop, goal=goal,
                                        stop_at_goal=stop.at_target)
    if job.spec.choice.mode == "robust":  # DE's final population (restored with it on a resume)
        job.population = (np.array(opt.pop), np.array(opt.fit))
    if job.spec.controls.random_search:
        gens = job.searches["search"].generations_run - 1
        job.searches["random_search"] = random_control(job, gens, phases.context("random_search"))
    done = job.searches.values()
    job.evaluations = sum(o.evaluations for o in done)
    job.sim_steps = sum(int(o.totals.get("sim_steps", 0)) for o in done)
    job.wall_s = sum(o.wall_s for o in done)


def random_control(job: _Job, generations: int, ctx: RunContext, cuts: bool | None = None) -> SearchOutcome:
    """The uniform random search over the search's bounds for ``generations`` generations
    after the first, on its own stream of the job's seed (adding the control leaves the
    search's draws alone). Its walks end once they cannot beat its best so far when
    ``cuts`` (default: ``controls.cut_walks``); a randomised search's control runs each
    generation on its draw, twice the generations: the same walks."""
    s = job.spec.search
    rnd = make_optimizer("random", job.lower, job.upper, s.population, control_seed(s.seed))
    if job.spec.randomised is not None:
        return run_search(rnd, lambda x: job.score.redrawn(rnd, x), 2 * generations, ctx)
    cuts = job.spec.controls.cut_walks if cuts is None else cuts

    def score(x: np.ndarray) -> Generation:
        return job.score.generation(x, rnd.selection_thresholds(), cuts=cuts)

    return run_search(rnd, score, generations, ctx)


def _enter(job: _Job, phases: Phases, name: str) -> PhaseContext:
    """A post-search phase begins: stop here on cancel (the searches' results are in the
    checkpoint, so a resume starts here) and say which one runs."""
    ph = phases.context(name)
    ph.tick(0, _search_info(job))
    return ph


def _search_info(job: _Job) -> dict:
    """What the progress line keeps showing after the search: its best F and evaluations."""
    return {"best": float(job.searches["search"].best_fitness), "evaluations": int(job.evaluations)}


def _done(job: _Job, ph: PhaseContext) -> None:
    ph.progress(1, 1, _search_info(job))  # the next phase's _enter checks for a cancel


def choose(job: _Job, phases: Phases) -> None:
    """choice.mode robust (spec.Choice): the answer becomes the member of DE's final population
    that meets the target on the nominal model and on the most of the choice's random models
    (then the fewest falls, then the best F); the search's best F when none meets it. Every
    later phase (controls, cases, held-out set, open loop, traces) judges the chosen gait."""
    c = job.spec.choice
    if c.mode != "robust":
        return
    ph = _enter(job, phases, "choice")
    pop, fit = job.population
    walk_s = job.spec.sim.duration_s
    nominal = job.ev.evaluate_all(pop)
    draws = draw_models(job.spec.seed, c.models, CHOICE_STREAM)
    ev = MultiModelEvaluator(job.robot, random_models(job.mspec, draws, job.robot.geometry.total_mass), job.seq,
                             job.ev.cfg)
    try:
        r = ev.evaluate_all(pop)
    finally:
        ev.close()
    job.evaluations += len(fit) * (1 + c.models)
    job.sim_steps += nominal.sim_steps + r.sim_steps
    P = len(fit)
    on_nominal = [target_met({k: v[p, 0] for k, v in nominal.metrics.items()}, walk_s) is True for p in range(P)]
    kept = np.array([[target_met({k: v[p, m] for k, v in r.metrics.items()}, walk_s) is True
                      for m in range(c.models)] for p in range(P)])
    falls = np.asarray(r.metrics["fell"], dtype=bool)
    best = int(np.argmax(fit))
    ok = [p for p in range(P) if on_nominal[p]]
    pick = min(ok, key=lambda p: (-int(kept[p].sum()), int(falls[p].sum()), -float(fit[p]), p)) if ok else best
    out = job.searches["search"]
    job.searches["search"] = dataclasses.replace(out, best_x=np.array(pop[pick]), best_fitness=float(fit[pick]))
    job.choice = {"mode": "robust", "models": c.models, "stream": "cases.CHOICE_STREAM of the job's seed",
                  "members": P, "meeting_target_nominally": len(ok), "chosen": pick, "best_fitness_member": best,
                  "chosen_kept": int(kept[pick].sum()), "chosen_fell": int(falls[pick].sum()),
                  "best_kept": int(kept[best].sum()), "best_fell": int(falls[best].sum()),
                  "chosen_fitness": float(fit[pick]), "best_fitness": float(fit[best]),
                  "best_fitness_params": _params(job.names, pop[best]),
                  "reason": ("of the members meeting the target on the nominal model, the one keeping it on the most "
                             "of the choice's models" if ok else "no member meets the target on the nominal model: "
                             "the best F")}
    _done(job, ph)


def controls(job: _Job, phases: Phases) -> None:
    """The answer and the nominal tripod re-scored; the random search's best beside them."""
    ph = _enter(job, phases, "final_scoring")
    w, u = job.spec.objective.weights, job.spec.objective.units
    job.best = _scored(job.ev, job.searches["search"].best_x, w, u)
    job.baseline = _scored(job.base_ev, job.nominal_x, w, u)
    job.evaluations += 2
    walk_s = job.spec.sim.duration_s
    met = target_met(job.baseline["metrics"], walk_s)
    note = ("already meets the target without recovery" if met else "does not meet the target" if met is False
            else "not judged (walk too short)") + (
        "; falls (chassis or upper leg on the ground)" if job.baseline["metrics"]["fell"] else "")
    job.controls = [ControlRow("baseline", "nominal tripod with nominal parameters (no recovery)",
                               job.baseline["metrics"], met, 1, note,
                               extra={"fitness": job.baseline["fitness"]}).to_json()]
    _done(job, ph)
    if "random_search" not in job.searches:
        return
    ph = _enter(job, phases, "random_search_scoring")
    rx = job.searches["random_search"].best_x
    rs = _scored(job.ev, rx, w, u)
    job.evaluations += 1
    s = job.spec
    beats = "beats" if rs["fitness"] > job.best["fitness"] else "does not beat"
    job.controls.append(ControlRow(
        "random_search", "uniform random search over the same bounds", rs["metrics"], target_met(rs["metrics"], walk_s),
        job.searches["random_search"].evaluations,  # the search's own count, fewer when a stop rule ended it
        "same budget, same scoring" + (" (robust)" if s.robust else "") + f"; {beats} the search's best F",
        extra={"fitness": rs["fitness"], "params": _params(job.names, rx)}).to_json())
    _done(job, ph)


def robustness(job: _Job, phases: Phases) -> None:
    """The answer re-simulated under each case, judged by the target; and, after a robust
    search, the answer's fitness on each model it was searched on."""
    best_x = job.searches["search"].best_x
    if job.rob_ev is not None:
        ph = _enter(job, phases, "robustness")
        r = job.rob_ev.evaluate_all(best_x)
        job.evaluations += len(job.cases)
        job.sim_steps += r.sim_steps
        w, u = job.spec.objective.weights, job.spec.objective.units
        rows = []
        for k, c in enumerate(job.cases):
            m = _scalars(r.metrics, k)
            f = float(fitness({key: v[:, k] for key, v in r.metrics.items()}, w, u)[0])
            rows.append({"name": c.name, "label": c.label, "metrics": m, "fitness": f,
                         "target_met": target_met(m, job.spec.sim.duration_s)})
        job.robustness = Robustness.build(target_for(job.spec.sim.duration_s).text, job.best["metrics"], rows).to_json()
        _done(job, ph)
    if job.spec.robust is not None:
        job.robust = job.spec.robust.model_dump() | {"best_per_model": job.score.per_model(best_x[None])}
    if job.spec.randomised is not None:  # the summary's robust block states the aggregate and K
        job.robust = {"randomised": job.score.describe(best_x, job.searches["search"].generations_run - 1)}


def held_out_and_open_loop(job: _Job, phases: Phases) -> None:
    """The answer on the held-out random models (a stream of the job's seed no search draws
    from); in closed loop, the answer once more without the correction, on the nominal
    model, every case and the held-out set: the correction's share, same models and seeds."""
    s, best_x = job.spec, job.searches["search"].best_x
    n = s.robustness.held_out

    def judge(m: dict) -> bool | None:
        return target_met(m, s.sim.duration_s)

    if n:
        ph = _enter(job, phases, "held_out")
        job.held_out, steps = held_out(job.mspec, job.robot, job.seq, job.ev.cfg, best_x, s.seed, n, judge)
        job.evaluations, job.sim_steps = job.evaluations + n, job.sim_steps + steps
        _done(job, ph)
    if job.ev.cfg.law is None:
        return
    ph = _enter(job, phases, "open_loop")
    cfg = dataclasses.replace(job.ev.cfg, law=None)  # the same walk without the correction, any robot
    ev = GaitEvaluator(job.robot, job.model, job.seq, cfg)
    best = _scored(ev, best_x, s.objective.weights, s.objective.units)
    ev.close()
    job.open_loop = {"best": best | {"target_met": judge(best["metrics"])}, "cases": []}
    job.evaluations += 1
    if job.cases:
        rob = MultiModelEvaluator(job.robot, case_models(job.mspec, job.model, job.cases), job.seq, cfg)
        r = rob.evaluate_all(best_x)
        rob.close()
        job.sim_steps += r.sim_steps
        job.evaluations += len(job.cases)
        job.open_loop["cases"] = [{"name": c.name, "metrics": _scalars(r.metrics, k),
                                   "target_met": judge(_scalars(r.metrics, k))} for k, c in enumerate(job.cases)]
    if n:
        job.open_loop["held_out"], steps = held_out(job.mspec, job.robot, job.seq, cfg, best_x, s.seed, n, judge)
        job.evaluations, job.sim_steps = job.evaluations + n, job.sim_steps + steps
    _done(job, ph)


def _robustness_json(job: _Job) -> dict | None:
    """The robustness block with the held-out set and the counts by group: numerics (the
    timestep checks) apart from the physical cases, and the held-out models apart from both."""
    if job.robustness is None and job.held_out is None:
        return None
    rob = dict(job.robustness or {"target": target_for(job.spec.sim.duration_s).text, "cases": [], "met": 0,
                                  "total": 0, "spread": {}})
    counts = Robustness.from_json(rob)
    rob["groups"] = {g: dict(zip(("met", "total"), counts.count(g))) for g in ("numerics", "physical")}
    if job.held_out is not None:
        rob["held_out"] = job.held_out
        rob["groups"]["held_out"] = {"met": job.held_out["met"], "total": job.held_out["n"]}
    return rob


def _control_json(job: _Job) -> dict:
    """How the gait was driven; in closed loop, the law and the answer without it."""
    law = job.ev.cfg.law
    if law is None:
        return {"mode": "open_loop"}
    return {"mode": "closed_loop", "law": law.as_dict(), "open_loop": job.open_loop}


def record_traces(job: _Job, phases: Phases) -> None:
    ph = _enter(job, phases, "traces")
    job.traces = {"best": job.ev.trace(job.searches["search"].best_x), "baseline": job.base_ev.trace(job.nominal_x)}
    _done(job, ph)


def _target_reached(out: SearchOutcome) -> dict:
    """When the stop rule on the target is on: the first generation whose best met it
    (confirmed), and the evaluations spent until then; None when it never did."""
    rows = [r for r in out.history if "target_met" in r]
    if not rows:
        return {}
    first = next((r for r in rows if r["target_met"]), None)
    return {"target_generation": None if first is None else first["generation"],
            "evaluations_to_target": None if first is None else first["evaluations"]}


def summary(job: _Job) -> dict:
    search_out = job.searches["search"]
    walk_s = job.spec.sim.duration_s  # the target scales with the walk (metrics.target_for)
    best = job.best | {"params": _params(job.names, search_out.best_x), "target_met": target_met(job.best["metrics"], walk_s)}
    baseline = job.baseline | {"params": _params(job.names, job.nominal_x), "gait": job.base_ev.seq.as_dict(),
                               "target_met": target_met(job.baseline["metrics"], walk_s)}
    return {
        "kind": "recovery",
        "robot": job.spec.robot,
        "damage": job.spec.damage.model_dump(),
        "seed": job.spec.seed,
        "baseline": baseline,
        "best": best,
        "target": {"text": target_for(walk_s).text, "walk_s": walk_s, "basis": basis_text(walk_s),
                   "best_met": best["target_met"], "baseline_met": baseline["target_met"],
                   "note": ("the baseline already meets the target: this damage needs no recovery"
                            if baseline["target_met"] else "")},
        "controls": job.controls,
        "robustness": _robustness_json(job),
        "control": _control_json(job),
        "robust": job.robust,
        "choice": job.choice,
        "gait": job.seq.as_dict() | {"period_s": job.ev.n_period * job.ev.dt},
        "timestep_s": float(job.model.opt.timestep),
        "bounds": {"names": job.names, "lower": job.lower.tolist(), "upper": job.upper.tolist()},
        "history": search_out.history,
        "random_search_history": job.searches["random_search"].history if "random_search" in job.searches else [],
        "search": {"stop_reason": search_out.stop_reason, "generations_run": search_out.generations_run}
        | _target_reached(search_out),
        "timing": {"wall_s": job.wall_s, "evaluations": job.evaluations,
                   "sim_steps_per_s": job.sim_steps / max(job.wall_s, 1e-9), "sim_steps": job.sim_steps,
                   "setup_s": job.setup_s, "time_to_target_s": search_out.time_to_target_s,
                   "cut_steps_saved": int(search_out.totals.get("cut_steps_saved", 0))},
    }


def run(spec: RecoverySpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    if spec.robot in ROBOTS:
        job = set_up(spec)
    else:  # an uploaded robot, as the service or the CLI stored it
        job = userrobot.set_up(spec, ctx.load_robot(spec.robot), _Job, scorer)
    try:
        phases = Phases(ctx, phase_sizes(spec))
        job.setup_s = time.perf_counter() - t0
        search(job, phases)
        post_start = time.perf_counter()
        choose(job, phases)
        controls(job, phases)
        robustness(job, phases)
        held_out_and_open_loop(job, phases)
        record_traces(job, phases)
        files = {} if spec.robot in ROBOTS else upload_files(job)  # its bundle's controller/
    finally:
        job.close()
    job.wall_s += time.perf_counter() - post_start  # the searches (across resumes) + the post-search steps
    extra = {"uploaded_robot": job.robot.summary()} if spec.robot not in ROBOTS else {}
    return JobResult(summary=summary(job) | extra, history=job.searches["search"].history, traces=job.traces,
                     model_xml=job.mspec.to_xml(), evaluations=job.evaluations, sim_steps=job.sim_steps, files=files)

"""Run an ``energy`` job: GA (paper 003) -> detailed evaluation of the best -> full-physics
check -> controls -> robustness. Search phases checkpoint every generation; the analysis
after them is deterministic and re-runs on resume.

The job is five steps over small state records: set-up (``_Job``), the searches
(``_Searches``), the answer in detail with its physics check (``_Answer``), the controls
and the robustness re-runs (``_Evidence``), and the summary."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from app.jobs.base import JobResult, RunContext
from app.jobs.energy.dynamics.gait import Gait, Task
from app.jobs.energy.dynamics.physics import PhysicsConfig, Reference, reference_from, simulate
from app.jobs.energy.dynamics.pipeline import PERIODICITY_TOL, EvalConfig, evaluate
from app.jobs.energy.problem import (PopulationEvaluator, Space, decode, encode_nominal, eval_config, geometry,
                                     space, task_of)
from app.jobs.energy.spec import EPS_RATIO_MIN, ROBUSTNESS_CASES, EnergySpec, walk_target
from app.jobs.evidence import (Case, CaseResult, ControlRow, PhaseContext, Phases, Robustness, Target, control_seed,
                               spread)
from app.jobs.loop import Carry, Generation, SearchOutcome, run_search
from app.optim.ga import GeneticAlgorithm
from app.optim.random_search import RandomSearch
from app.robots.quadruped import LEGS, QuadrupedGeometry, build_spec

# The play-back as the spec sets it: every scale of a robustness case at 1 (exact: x * 1.0 == x).
_AS_SPECIFIED = Case("as_specified", "the world as specified")
_SPREAD_KEYS = ("speed_m_s", "mean_height_m", "cot")


# -- the state the steps pass on ----------------------------------------------------------------

@dataclasses.dataclass
class _Job:
    """What set-up derives from the spec and every later step reads."""

    spec: EnergySpec
    sp: Space
    task: Task
    cfg: EvalConfig
    target: Target
    phases: Phases
    analysis: PhaseContext  # after the searches: the answer, the physics check, controls, robustness
    t_start: float


@dataclasses.dataclass
class _Searched:
    """One search's outcome and the evaluation row of its best candidate (the controls and
    the summary need more of it than its J)."""

    out: SearchOutcome
    row: dict[str, Any]


@dataclasses.dataclass
class _Searches:
    best_x: np.ndarray
    history: list[dict[str, Any]]
    t_end: float  # when the searches ended: this attempt's analysis time counts from here
    evaluations: int = 0
    wall_s: float = 0.0  # the searches' wall time, summed over resumed attempts
    ga: _Searched | None = None
    rs: _Searched | None = None


@dataclasses.dataclass
class _Answer:
    """The answer evaluated in detail and, when every stage ran, played in MuJoCo."""

    gait: Gait
    links: tuple[float, float, float]
    geom: QuadrupedGeometry
    best: dict[str, Any]
    ref: Reference | None = None
    phys: dict[str, Any] | None = None
    phys_other: dict[str, Any] | None = None
    phys_raw: dict[str, Any] | None = None
    sim_steps: int = 0


@dataclasses.dataclass
class _Evidence:
    controls: list[ControlRow] = dataclasses.field(default_factory=list)
    analysis: dict[str, Any] = dataclasses.field(default_factory=dict)
    robustness: Robustness | None = None


# -- the job ----------------------------------------------------------------------------------

def run(spec: EnergySpec, ctx: RunContext) -> JobResult:
    job = _set_up(spec, ctx)
    found = _search(job)
    answer = _answer(job, found)
    evidence = _Evidence()
    if spec.evidence.controls:
        _controls(job, found, answer, evidence)
    if spec.evidence.robustness and answer.ref is not None:
        evidence.robustness = _robustness(job, answer)
    return _result(job, found, answer, evidence)


def _set_up(spec: EnergySpec, ctx: RunContext) -> _Job:
    t_start = time.perf_counter()
    sizes: dict[str, int] = {}
    if spec.search.optimizer == "ga":
        n = spec.search_evaluations
        sizes = {"ga": n} | ({"random_search": n} if spec.evidence.random_search else {})
    # The analysis's share is the searches' complement: when a stop rule ends them early the
    # bar jumps over what they skipped and never runs backwards.
    phases = Phases(ctx, sizes | {"analysis": spec.evaluations_budget - sum(sizes.values())})
    return _Job(spec=spec, sp=space(spec), task=task_of(spec), cfg=eval_config(spec),
                target=walk_target(spec.task.speed_m_s, spec.physics.periods), phases=phases,
                analysis=phases.context("analysis"), t_start=t_start)


# -- the searches -----------------------------------------------------------------------------

class _Minimising:
    """The GA minimises J; the shared loop maximises its fitness -J (negation is exact, so
    the GA sees the same numbers as before)."""

    def __init__(self, ga: GeneticAlgorithm):
        self.ga = ga

    @property
    def generation(self) -> int:
        return self.ga.generation

    def ask(self) -> np.ndarray:
        return self.ga.ask()

    def tell(self, fitness) -> None:
        self.ga.tell(-np.asarray(fitness, dtype=float))

    @property
    def best(self) -> tuple[np.ndarray, float]:
        x, j = self.ga.best
        return x, -j

    def state(self) -> dict:
        return self.ga.state()

    def restore(self, state: dict) -> None:
        self.ga.restore(state)


class _Evaluation:
    """A search's evaluate for the shared loop: a population's evaluation rows become its
    Generation; the row of the best candidate so far is kept, and rides in the search's
    checkpoint (``carry``) so a resumed search has it too."""

    def __init__(self, evaluator: PopulationEvaluator):
        self.evaluator = evaluator
        self.row: dict[str, Any] | None = None
        self.feasible_share = 0.0

    def __call__(self, X: np.ndarray) -> Generation:
        rows = self.evaluator(X)
        J = np.array([r["fitness"] for r in rows])
        i = int(np.argmin(J))
        if self.row is None or J[i] < self.row["fitness"]:
            self.row = rows[i]
        feas = [r["fitness"] for r in rows if r["feasible"]]
        self.feasible_share = len(feas) / len(rows)
        return Generation(-J, {"feasible_share": self.feasible_share,
                               "mean_feasible": float(np.mean(feas)) if feas else None,
                               "best_cot": self.row.get("cot_final")})

    def info(self, info: dict) -> dict:
        return info | {"best_J": info["best"], "feasible_share": self.feasible_share}

    def carry(self) -> Carry:
        return Carry("best_row", lambda: self.row, self._restore)

    def _restore(self, row: dict[str, Any] | None) -> None:
        self.row = row


def _run_one(job: _Job, name: str, opt, evaluator: PopulationEvaluator, generations: int, rules) -> _Searched:
    """One search (the GA or its control) through the shared loop (app/jobs/loop.py):
    generation 0 is the initial population, ``generations`` more follow unless a stop
    rule ends it; checkpoints after every generation, stops on cancel between them."""
    ev = _Evaluation(evaluator)
    out = run_search(opt, ev, generations, job.phases.context(name), rules, sign=-1.0, progress_info=ev.info,
                     carry=ev.carry())
    return _Searched(out, ev.row)


def _search(job: _Job) -> _Searches:
    """The GA and its equal-budget control: uniform random search over the same box, as
    many generations as the GA ran (fewer when a stop rule ended it). Without a search the
    answer is Table 1's design."""
    spec, sp = job.spec, job.sp
    if spec.search.optimizer != "ga":
        return _Searches(best_x=encode_nominal(sp, spec), history=[], t_end=job.t_start)
    evaluator = PopulationEvaluator(spec)
    try:
        ga = GeneticAlgorithm(sp.lower, sp.upper, population=spec.search.population, seed=spec.search.seed)
        st = _run_one(job, "ga", _Minimising(ga), evaluator, spec.search.generations, spec.stop)
        found = _Searches(best_x=st.out.best_x, history=st.out.history, t_end=0.0, evaluations=st.out.evaluations,
                          wall_s=st.out.wall_s, ga=st)
        if spec.evidence.random_search:
            rs = RandomSearch(sp.lower, sp.upper, population=spec.search.population,
                              seed=control_seed(spec.search.seed))
            found.rs = _run_one(job, "random_search", rs, evaluator, st.out.generations_run - 1, None)
            found.history = _merge_history(found.history, found.rs.out.history)
            found.evaluations += found.rs.out.evaluations
            found.wall_s += found.rs.out.wall_s
    finally:
        evaluator.close()
    found.t_end = time.perf_counter()
    return found


def _merge_history(ga: list[dict], rs: list[dict]) -> list[dict]:
    """One row per generation: the GA's columns and its random-search control's beside them."""
    by_gen = {r["generation"]: r for r in rs}
    out = []
    for row in ga:
        r = by_gen.get(row["generation"])
        row = {k: v for k, v in row.items() if k != "phase"}
        if r is not None:
            row |= {"random_search_best": r["best"], "random_search_generation_best": r["generation_best"],
                    "random_search_feasible_share": r["feasible_share"]}
        out.append(row)
    return out


# -- the answer in detail and in physics ------------------------------------------------------

def _answer(job: _Job, found: _Searches) -> _Answer:
    job.analysis.check()
    gait, links = decode(job.sp, found.best_x)
    geom = geometry(job.spec, links)
    a = _Answer(gait, links, geom, evaluate(geom, gait, job.task, job.cfg, detail=True))
    job.analysis.tick(1, {"step": "best in detail"})
    tr = a.best.get("trajectories")
    if tr is not None:  # every stage ran: the answer can be played back
        _physics_check(job, a, tr)
    return a


def _physics_check(job: _Job, a: _Answer, tr: dict[str, Any]) -> None:
    """The answer played in MuJoCo with the spec's feedback, and with the other feedback:
    none (joint PD only) or, when the spec has none, the default foot placement."""
    ph = job.spec.physics
    a.ref = reference_from(tr, a.gait, job.task.speed)
    feedback = ph.balance or ph.foot_placement > 0
    other = 0.0 if feedback else 0.5
    p = _physics(job, a)
    p2 = _physics(job, a, balance=False, foot_placement=other)
    a.sim_steps += p["steps"] + p2["steps"]
    ref_cot = a.best["cot"]["qp"]
    a.phys = _physics_summary(p, ref_cot, job.target) | {"feedback": _feedback_text(ph.balance, ph.foot_placement)}
    a.phys_other = _physics_summary(p2, ref_cot, job.target) | {"feedback": _feedback_text(False, other)}
    a.phys_raw = p
    job.analysis.tick(2, {"step": "physics check", "stays_up": a.phys["stays_up"]})


def _physics(job: _Job, a: _Answer, balance: bool | None = None, foot_placement: float | None = None,
             case: Case = _AS_SPECIFIED) -> dict[str, Any]:
    ph = job.spec.physics
    stance = max(a.ref.duty) * a.ref.period
    friction = job.task.friction * case.friction_scale
    cfg = PhysicsConfig(periods=ph.periods, timestep=ph.timestep_s * case.timestep_scale,
                        balance=ph.balance if balance is None else balance,
                        foot_placement_s=(ph.foot_placement if foot_placement is None else foot_placement) * stance,
                        friction=friction, mass_scale=case.mass_scale)
    return simulate(a.geom, a.ref, friction, cfg)


def _physics_summary(p: dict, ref_cot: float, target: Target) -> dict[str, Any]:
    out = {k: p[k] for k in ("stays_up", "fell_at_s", "periods_completed", "speed_m_s", "mean_height_m", "cot",
                             "cot_feedforward_part", "drift_per_period", "duration_s")}
    out["cot"], out["cot_feedforward_part"] = float(out["cot"]), float(out["cot_feedforward_part"])
    out["feedback_cot_share"] = (out["cot"] - out["cot_feedforward_part"]) / out["cot"] if out["cot"] > 0 else None
    out["cot_vs_model"] = out["cot"] / ref_cot - 1.0 if ref_cot > 0 else None
    out["target_met"] = target.met(p)
    return out


def _feedback_text(balance: bool, foot_placement: float) -> str:
    parts = []
    if foot_placement > 0:
        parts.append(f"foot placement {foot_placement:g} x stance time")
    if balance:
        parts.append("trunk rate damping")
    return " + ".join(parts) if parts else "joint PD only"


# -- the controls -----------------------------------------------------------------------------

def _metrics(r: dict) -> dict[str, Any]:
    if "cot" not in r:
        return {"feasible": False, "failed": r["failed"], "J": r["fitness"]}
    return {"feasible": r["feasible"], "J": r["fitness"], "cot_nlp_first": r["cot"]["nlp_first"],
            "cot_nlp": r["cot"]["nlp"], "cot_qp": r["cot"]["qp"],
            "cot_final": r["cot"]["final"], "eps_nlp_N": r["eps"]["nlp"]["norm"], "eps_qp_N": r["eps"]["qp"]["norm"],
            "periodicity_error": r["periodicity_error"]}


def _controls(job: _Job, found: _Searches, a: _Answer, ev: _Evidence) -> None:
    """The random search's row (its search already ran), then each analysis control; the
    progress names the control about to run, counting the evaluations of those before it."""
    if found.rs is not None:
        ev.controls.append(_random_search_row(found.rs, a.best))
    ran = 0  # the evaluations of the control before: counted when the next one is announced
    for name, control in _CONTROLS:
        job.analysis.tick(ran, {"step": "control", "control": name})
        ran = control(job, a, ev)
    job.analysis.tick(ran, {"step": "controls"})


def _random_search_row(rs: _Searched, best: dict) -> ControlRow:
    row, better = rs.row, bool(best["fitness"] < rs.row["fitness"])
    return ControlRow("random_search", "uniform random search over the same bounds",
                      {"J": row["fitness"], "feasible": row["feasible"], "cot_final": row.get("cot_final"),
                       "ga_J": best["fitness"], "ga_better": better},
                      better, rs.out.evaluations, "same population x generations as the GA; the GA's answer is "
                      "target_met when its J is lower")


def _table1_design(job: _Job) -> tuple[Gait, tuple[float, float, float]]:
    return decode(job.sp, encode_nominal(job.sp, job.spec))


def _paper_table1(job: _Job, a: _Answer, ev: _Evidence) -> int:
    """Table 1's own timing with Table 1 links."""
    g0, l0 = _table1_design(job)
    base = evaluate(geometry(job.spec, l0), g0, job.task, job.cfg)
    ev.controls.append(ControlRow("paper_table1", "Table 1 timing (T = 0.46 s) with Table 1 links",
                                  _metrics(base) | {"ga_J": a.best["fitness"]},
                                  bool(a.best["fitness"] <= base["fitness"]), 1,
                                  "the paper's own gait, evaluated by the same pipeline"))
    ev.analysis["table1"] = _metrics(base)
    return 1


def _srb_only(job: _Job, a: _Answer, ev: _Evidence) -> int:
    """SRB-only (massless legs in the NLP), re-evaluated on the heavy-legged robot, and on
    massless legs: a milligram rod per link (MuJoCo needs some mass on a moving body)."""
    no_legs = dataclasses.replace(job.cfg, leg_dynamics=False)
    srb = evaluate(a.geom, a.gait, job.task, no_legs)
    light = dataclasses.replace(a.geom, link_masses=(1e-6, 1e-6, 1e-6), inertia="rod")
    massless = evaluate(light, a.gait, job.task, no_legs)
    best = a.best
    cmp = {"srb_on_heavy_legs": _metrics(srb), "srb_on_massless_legs": _metrics(massless),
           "leg_dynamics": _metrics(best)}
    if "cot" in massless and "cot" in srb:
        cmp["cot_increase_heavy_vs_massless"] = srb["cot"]["final"] / massless["cot"]["final"] - 1.0
    ev.analysis["srb_vs_legs"] = cmp
    ev.controls.append(ControlRow(
        "srb_only", "SRB with massless legs (paper ref. [10]), re-evaluated on the heavy legs",
        {"eps_nlp_N": _metrics(srb).get("eps_nlp_N"),
         "eps_nlp_legs_N": best["eps"]["nlp"]["norm"] if "eps" in best else None,
         "cot_final": _metrics(srb).get("cot_final"), "cot_massless": _metrics(massless).get("cot_nlp"),
         "feasible": srb["feasible"]},
        bool("eps" in srb and "eps" in best and best["eps"]["nlp"]["norm"] < srb["eps"]["nlp"]["norm"]), 2,
        "target_met when the dummy legs leave a smaller residual than massless legs"))
    return 2


def _high_step(job: _Job, a: _Answer, ev: _Evidence) -> int:
    """The same design with a higher swing (obstacle clearance), and Table 1's."""
    height = job.spec.evidence.high_step_swing_height_m
    high = task_of(job.spec, swing_height=height)
    g0, l0 = _table1_design(job)
    hs = evaluate(a.geom, a.gait, high, job.cfg)
    hs0 = evaluate(geometry(job.spec, l0), g0, high, job.cfg)
    ev.analysis["high_step"] = {"swing_height_m": height, "best_design": _metrics(hs), "table1": _metrics(hs0)}
    ev.controls.append(ControlRow(
        "high_step", f"swing height {height} m (best design and Table 1 re-evaluated)",
        {"best_" + k: v for k, v in _metrics(hs).items()} | {"table1_" + k: v for k, v in _metrics(hs0).items()},
        bool(hs["feasible"] or hs0["feasible"]), 2,
        "not re-optimised; a calf and thigh of unequal length cannot fold the foot as close to the hip"))
    return 2


def _rod_inertia(job: _Job, a: _Answer, ev: _Evidence) -> int:
    """Table 1's inertias vs the ones a slender rod of that mass and length has."""
    rod = evaluate(dataclasses.replace(a.geom, inertia="rod"), a.gait, job.task, job.cfg)
    ev.analysis["rod_inertia"] = _metrics(rod)
    ev.controls.append(ControlRow("rod_inertia", "link inertias of slender rods instead of Table 1's", _metrics(rod),
                                  None, 1, "papers README: Table 1's inertias are 10-1000x a slender link's"))
    return 1


def _no_residual_iteration(job: _Job, a: _Answer, ev: _Evidence) -> int:
    """Ablation of the residual iteration (the paper's single NLP pass)."""
    single = evaluate(a.geom, a.gait, job.task, dataclasses.replace(job.cfg, residual_iterations=0))
    ms = _metrics(single)
    if "eps_qp_N" in ms:
        ms["eps_ratio"] = ms["eps_nlp_N"] / max(ms["eps_qp_N"], 1e-12)
    ev.controls.append(ControlRow(
        "no_residual_iteration", "the paper's single NLP pass (no re-solve with the legs' true wrench)", ms,
        bool("eps_ratio" in ms and ms["eps_ratio"] >= EPS_RATIO_MIN), 1,
        f"target: eps_QP {EPS_RATIO_MIN:g}x below eps_NLP"))
    return 1


# In this order; each returns the evaluations it ran (EnergySpec.budget_formula counts 7).
_CONTROLS = (("paper_table1", _paper_table1), ("srb_only", _srb_only), ("high_step", _high_step),
             ("rod_inertia", _rod_inertia), ("no_residual_iteration", _no_residual_iteration))


# -- robustness -------------------------------------------------------------------------------

def _robustness(job: _Job, a: _Answer) -> Robustness:
    """The answer re-played under every case, judged by the kind's target."""
    cases, steps = [], 0
    for c in ROBUSTNESS_CASES:
        p = _physics(job, a, case=c)
        steps += p["steps"]
        s = _physics_summary(p, a.phys["cot"], job.target)
        cases.append(CaseResult(c.name, c.label, {
            "stays_up": s["stays_up"], "speed_m_s": s["speed_m_s"], "mean_height_m": s["mean_height_m"],
            "cot": s["cot"], "periods_completed": s["periods_completed"],
            "drift_angle_rad": s["drift_per_period"].get("angle_rad")}, s["target_met"]))
        job.analysis.tick(1, {"phase": "robustness", "case": c.name, "stays_up": s["stays_up"]})
    return Robustness(job.target.text, cases, _spread(cases, a.phys), {"sim_steps": steps})


def _spread(cases: list[CaseResult], nominal: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Energy's range is over the cases alone, the nominal stated beside it (evidence.spread
    would take the nominal into the range: a nominal outside the cases' range would move
    min or max), so the nominal is left out of the call and written after."""
    out = spread({}, [c.to_json() for c in cases], _SPREAD_KEYS)
    for k, v in out.items():
        v["nominal"] = nominal[k]
    return out


# -- the summary ------------------------------------------------------------------------------

def _result(job: _Job, found: _Searches, a: _Answer, ev: _Evidence) -> JobResult:
    done = found.evaluations + job.analysis.done
    wall = found.wall_s + time.perf_counter() - found.t_end  # the searches over every attempt, then this analysis
    summary = _summary(job, found, a, ev) | {"timing": _timing(a.best, wall, done)}
    model_xml = build_spec(dataclasses.replace(a.geom, timestep=job.spec.physics.timestep_s)).to_xml()
    rob_steps = ev.robustness.extra["sim_steps"] if ev.robustness is not None else 0
    return JobResult(summary=summary, history=found.history, traces=_traces(a.best, a.phys_raw), model_xml=model_xml,
                     evaluations=done, sim_steps=int(a.sim_steps + rob_steps))


def _summary(job: _Job, found: _Searches, a: _Answer, ev: _Evidence) -> dict[str, Any]:
    spec, best = job.spec, a.best
    s: dict[str, Any] = {"kind": "energy", "robot": spec.robot, "seed": spec.seed,
                         "task": spec.task.model_dump(), "family": spec.gait.family,
                         "gait": _gait_summary(a.gait), "links_m": list(a.links),
                         "link_masses_kg": a.geom.masses().tolist(), "total_mass_kg": a.geom.total_mass,
                         "inertia": a.geom.inertia, "feasible": best["feasible"], "failed": best["failed"],
                         "J": best["fitness"]}
    if "cot" in best:
        s |= _stages(best, a.phys, spec.model.jerk_weight)
    s["physics"] = a.phys
    s["physics_other_feedback"] = a.phys_other
    if found.ga is not None:
        out = found.ga.out
        s["search"] = {"optimizer": "ga", "population": spec.search.population, "generations": spec.search.generations,
                       "evaluations": out.evaluations, "best_J": found.ga.row["fitness"],
                       "stop_reason": out.stop_reason, "generations_run": out.generations_run}
    s["analysis"] = ev.analysis
    s["controls"] = [c.to_json() for c in ev.controls]
    if ev.robustness is not None:
        s["robustness"] = ev.robustness.to_json()
    return s


def _stages(best: dict, phys: dict | None, jerk_weight: float) -> dict[str, Any]:
    """The answer's every stage (NLP, QP, forward check), when they all ran."""
    return {"cot": dict(best["cot"]) | {"physics": phys["cot"] if phys else None},
            "objective": {"J": best["fitness"], "cot": best["objective_terms"]["cot"],
                          "jerk_term_N_s": best["jerk_term_N_s"], "jerk_weight_s": jerk_weight},
            "eps": best["eps"],
            "eps_ratio_nlp_over_qp": best["eps"]["nlp"]["norm"] / max(best["eps"]["qp"]["norm"], 1e-12),
            "periodicity_error": best["periodicity_error"], "periodicity": best["periodicity"],
            "periodicity_tolerance": PERIODICITY_TOL,
            "nlp_forward_periodicity_error": best.get("nlp_forward_periodicity_error"),
            "nlp": {k: v for k, v in best["nlp"].items() if k != "seconds"}}


def _timing(best: dict, wall: float, done: int) -> dict[str, Any]:
    """Measured times live here: the rest of the summary is the same for the same spec and seed."""
    out: dict[str, Any] = {"wall_s": wall, "evaluations": done}
    if "cot" in best:  # every stage ran
        out["fitness_eval_s"] = best["timings_s"] | {"nlp_solver": best["nlp"].get("seconds")}
    return out


def _gait_summary(gait: Gait) -> dict[str, Any]:
    return {"period_s": gait.period, "touchdown_s": list(gait.touchdown), "duty": list(gait.duty), "legs": list(LEGS)}


def _traces(best: dict, phys: dict | None) -> dict[str, dict[str, np.ndarray]]:
    tr = best.get("trajectories")
    if tr is None:
        return {}
    sol, first, fwd, fwd_nlp = tr["nlp"], tr["nlp_first"], tr["final"], tr["forward_nlp"]
    n_s = len(tr["t_samples"])
    out = {
        "body": {"time_s": tr["t_knots"], **{f"nlp_{k}": getattr(first, k) for k in ("r", "theta")},
                 **{f"nlp_iterated_{k}": getattr(sol, k) for k in ("r", "theta")},
                 **{f"final_{k}": getattr(fwd, k) for k in ("r", "theta")},
                 **{f"forward_nlp_{k}": getattr(fwd_nlp, k) for k in ("r", "theta")}},
        "forces": {"time_s": tr["t_samples"], "f_nlp": tr["f_nlp_first"].reshape(n_s, 12),
                   "f_nlp_iterated": tr["f_nlp"].reshape(n_s, 12), "f_qp": tr["f_qp"].reshape(n_s, 12),
                   "wrench_nlp": tr["wrench_nlp_first"], "wrench_qp": tr["wrench_qp"],
                   "eps_nlp": tr["eps_nlp_first"], "eps_nlp_iterated": tr["eps_nlp"], "eps_qp": tr["eps_qp"],
                   "tau_final": tr["tau_final"], "stance": tr["stance"].astype(np.int8)},
    }
    if phys is not None:
        out["physics"] = {"time_s": phys["frames_t"], "qpos": phys["frames_qpos"]}
    return out

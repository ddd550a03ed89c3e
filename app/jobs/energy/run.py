"""Run an ``energy`` job: GA (paper 003) -> detailed evaluation of the best -> full-physics
check -> controls -> robustness. Search phases checkpoint every generation; the analysis
after them is deterministic and re-runs on resume."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from app.jobs.energy.dynamics.gait import Gait
from app.jobs.energy.dynamics.physics import PhysicsConfig, reference_from, simulate
from app.jobs.energy.dynamics.pipeline import PERIODICITY_TOL, evaluate
from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.evidence import Phases
from app.jobs.loop import Generation, run_search
from app.jobs.energy.problem import (PopulationEvaluator, decode, encode_nominal, eval_config, geometry,
                                     space, task_of)
from app.jobs.energy.spec import ROBUSTNESS_CASES, EnergySpec
from app.optim.ga import GeneticAlgorithm
from app.optim.random_search import RandomSearch
from app.robots.quadruped import LEGS, build_spec

SPEED_TOL = 0.1  # physics target: realised speed within 10 % of V, and up for every period


def _gait_summary(gait: Gait) -> dict[str, Any]:
    return {"period_s": gait.period, "touchdown_s": list(gait.touchdown), "duty": list(gait.duty), "legs": list(LEGS)}


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


class _SearchPhase:
    """One search phase's run context plus what the controls and the summary need beyond
    the loop's history: the evaluation row of the best candidate so far. It rides in the
    phase's checkpoint, so a resumed search keeps it."""

    def __init__(self, ctx, evaluator):
        self.ctx, self.evaluator = ctx, evaluator
        self.artifact_dir = ctx.artifact_dir
        self.row: dict | None = None
        self.feasible_share = 0.0

    def load_checkpoint(self):
        state = self.ctx.load_checkpoint()
        if state is not None:
            self.row = state.get("best_row")
        return state

    def save_checkpoint(self, state: dict) -> None:
        self.ctx.save_checkpoint(state | {"best_row": self.row})

    def progress(self, done: int, total: int, info: dict) -> None:
        self.ctx.progress(done, total, info)

    def is_cancelled(self) -> bool:
        return self.ctx.is_cancelled()

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


class _Skipped:
    """The analysis's progress after searches a stop rule ended early: the bar counts the
    searches' whole share as done, so it never runs backwards."""

    def __init__(self, ctx, skipped: int):
        self.ctx, self.skipped = ctx, skipped

    def progress(self, done: int, total: int, info: dict) -> None:
        self.ctx.progress(done + self.skipped, total, info)

    def is_cancelled(self) -> bool:
        return self.ctx.is_cancelled()


def _search(opt, phase: _SearchPhase, generations: int, rules) -> dict:
    """One search (the GA or its control) through the shared loop (app/jobs/loop.py):
    generation 0 is the initial population, ``generations`` more follow unless a stop
    rule ends it; checkpoints after every generation, stops on cancel between them."""
    out = run_search(opt, phase, generations, phase, rules, sign=-1.0, progress_info=phase.info)
    return {"best_x": out.best_x, "best": {"row": phase.row}, "history": out.history, "evaluations": out.evaluations,
            "wall_s": out.wall_s, "stop_reason": out.stop_reason, "generations_run": out.generations_run}


def _physics_summary(p: dict, ref_cot: float, speed: float) -> dict[str, Any]:
    out = {k: p[k] for k in ("stays_up", "fell_at_s", "periods_completed", "speed_m_s", "mean_height_m", "cot",
                             "cot_feedforward_part", "drift_per_period", "duration_s")}
    out["cot"], out["cot_feedforward_part"] = float(out["cot"]), float(out["cot_feedforward_part"])
    out["feedback_cot_share"] = (out["cot"] - out["cot_feedforward_part"]) / out["cot"] if out["cot"] > 0 else None
    out["cot_vs_model"] = out["cot"] / ref_cot - 1.0 if ref_cot > 0 else None
    out["target_met"] = bool(p["stays_up"] and abs(p["speed_m_s"] - speed) <= SPEED_TOL * speed)
    return out


def _physics(spec, geom, ref, task, **over):
    ph = spec.physics
    stance = max(ref.duty) * ref.period
    cfg = PhysicsConfig(periods=ph.periods, timestep=ph.timestep_s, balance=ph.balance,
                        foot_placement_s=over.get("foot_placement", ph.foot_placement) * stance)
    friction = task.friction
    if "timestep_scale" in over:
        cfg = dataclasses.replace(cfg, timestep=cfg.timestep * over["timestep_scale"])
    if "friction_scale" in over:
        friction = friction * over["friction_scale"]
    if "mass_scale" in over:
        cfg = dataclasses.replace(cfg, mass_scale=over["mass_scale"])
    if "balance" in over:
        cfg = dataclasses.replace(cfg, balance=over["balance"])
    return simulate(geom, ref, friction, dataclasses.replace(cfg, friction=friction))


def run(spec: EnergySpec, ctx: RunContext) -> JobResult:
    t_start = time.perf_counter()
    total = spec.evaluations_budget
    sp = space(spec)
    task = task_of(spec)
    cfg = eval_config(spec)
    evaluator = PopulationEvaluator(spec) if spec.search.optimizer == "ga" else None
    search_wall = 0.0
    try:
        if spec.search.optimizer == "ga":
            n = spec.search_evaluations
            sizes = {"ga": n} | ({"random_search": n} if spec.evidence.random_search else {})
            phases = Phases(ctx, sizes | {"analysis": total - sum(sizes.values())})
            # --- the GA ---------------------------------------------------------------------
            ga = GeneticAlgorithm(sp.lower, sp.upper, population=spec.search.population, seed=spec.search.seed)
            st = _search(_Minimising(ga), _SearchPhase(phases.context("ga"), evaluator), spec.search.generations,
                         spec.stop)
            best_x, history, done = st["best_x"], st["history"], st["evaluations"]
            search_wall += st["wall_s"]
            # --- its equal-budget control: uniform random search over the same box, as many
            # generations as the GA ran (fewer when a stop rule ended it) ---------------------
            rs_state = None
            if spec.evidence.random_search:
                rs = RandomSearch(sp.lower, sp.upper, population=spec.search.population,
                                  seed=spec.search.seed + 7919)
                rs_state = _search(rs, _SearchPhase(phases.context("random_search"), evaluator),
                                   st["generations_run"] - 1, None)
                history = _merge_history(history, rs_state["history"])
                done += rs_state["evaluations"]
                search_wall += rs_state["wall_s"]
        else:
            best_x, history, done, rs_state, st = encode_nominal(sp, spec), [], 0, None, None
    finally:
        if evaluator is not None:
            evaluator.close()
    t_post = time.perf_counter()
    if st is not None and done < sum(sizes.values()):
        ctx = _Skipped(ctx, sum(sizes.values()) - done)  # a stop rule ended the searches early

    # --- the answer in detail --------------------------------------------------------------
    if ctx.is_cancelled():
        raise Cancelled()
    gait, links = decode(sp, best_x)
    geom = geometry(spec, links)
    best = evaluate(geom, gait, task, cfg, detail=True)
    done += 1
    ctx.progress(done, total, {"phase": "analysis", "step": "best in detail"})
    tr = best.get("trajectories")
    phys, phys_other, ref, phys_raw = None, None, None, None
    sim_steps = 0
    if tr is not None:
        if ctx.is_cancelled():
            raise Cancelled()
        ref = reference_from(tr, gait, task.speed)
        p = _physics(spec, geom, ref, task)
        phys = _physics_summary(p, best["cot"]["qp"], task.speed)
        phys_raw = p
        feedback = spec.physics.balance or spec.physics.foot_placement > 0
        p2 = (_physics(spec, geom, ref, task, balance=False, foot_placement=0.0) if feedback
              else _physics(spec, geom, ref, task, foot_placement=0.5))
        sim_steps += p["steps"] + p2["steps"]
        phys_other = _physics_summary(p2, best["cot"]["qp"], task.speed)
        phys["feedback"] = _feedback_text(spec.physics.balance, spec.physics.foot_placement)
        phys_other["feedback"] = _feedback_text(False, 0.0) if feedback else _feedback_text(False, 0.5)
        done += 2
        ctx.progress(done, total, {"phase": "analysis", "step": "physics check", "stays_up": phys["stays_up"]})

    controls, analysis = [], {}
    if spec.evidence.controls:
        controls, analysis, n = _controls(spec, sp, best_x, best, gait, links, task, cfg, st, rs_state, ctx, done, total)
        done += n
    robustness = None
    if spec.evidence.robustness and ref is not None:
        robustness = _robustness(spec, geom, ref, task, phys, ctx, done, total)
        done += len(ROBUSTNESS_CASES)

    # the searches' wall time summed over resumed attempts, then this attempt's analysis
    wall = (search_wall + time.perf_counter() - t_post) if st is not None else time.perf_counter() - t_start
    summary = _summary(spec, best, gait, links, geom, phys, phys_other, controls, analysis, robustness, st, wall, done)
    traces = _traces(best, phys_raw)
    model_xml = build_spec(dataclasses.replace(geom, timestep=spec.physics.timestep_s)).to_xml()
    return JobResult(summary=summary, history=history, traces=traces, model_xml=model_xml, evaluations=done,
                     sim_steps=int(sim_steps + (robustness or {}).get("sim_steps", 0)))


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


def _feedback_text(balance: bool, foot_placement: float) -> str:
    parts = []
    if foot_placement > 0:
        parts.append(f"foot placement {foot_placement:g} x stance time")
    if balance:
        parts.append("trunk rate damping")
    return " + ".join(parts) if parts else "joint PD only"


def _row(name, label, evaluations, metrics, target_met, note):
    return {"name": name, "label": label, "evaluations": evaluations, "metrics": metrics, "target_met": target_met,
            "note": note}


def _metrics(r: dict) -> dict[str, Any]:
    if "cot" not in r:
        return {"feasible": False, "failed": r["failed"], "J": r["fitness"]}
    return {"feasible": r["feasible"], "J": r["fitness"], "cot_nlp_first": r["cot"]["nlp_first"],
            "cot_nlp": r["cot"]["nlp"], "cot_qp": r["cot"]["qp"],
            "cot_final": r["cot"]["final"], "eps_nlp_N": r["eps"]["nlp"]["norm"], "eps_qp_N": r["eps"]["qp"]["norm"],
            "periodicity_error": r["periodicity_error"]}


def _controls(spec, sp, best_x, best, gait, links, task, cfg, st, rs_state, ctx, done, total):
    controls, analysis = [], {}
    n = 0

    def unit(name: str) -> None:
        """Before each control's evaluations: stop on cancel, say which control runs."""
        if ctx.is_cancelled():
            raise Cancelled()
        ctx.progress(done + n, total, {"phase": "analysis", "step": "control", "control": name})
    target = "feasible (periodic within tolerance) with a lower J than the control"
    if rs_state is not None and rs_state["best"] is not None:
        row = rs_state["best"]["row"]
        controls.append(_row(
            "random_search", "uniform random search over the same bounds", rs_state["evaluations"],
            {"J": row["fitness"], "feasible": row["feasible"], "cot_final": row.get("cot_final"),
             "ga_J": best["fitness"], "ga_better": bool(best["fitness"] < row["fitness"])},
            bool(best["fitness"] < row["fitness"]), "same population x generations as the GA; the GA's answer "
            "is target_met when its J is lower"))
    # Table 1's own timing with Table 1 links.
    unit("paper_table1")
    nominal = encode_nominal(sp, spec)
    g0, l0 = decode(sp, nominal)
    base = evaluate(geometry(spec, l0), g0, task, cfg)
    n += 1
    m = _metrics(base)
    m["ga_J"] = best["fitness"]
    controls.append(_row("paper_table1", "Table 1 timing (T = 0.46 s) with Table 1 links", 1, m,
                         bool(best["fitness"] <= base["fitness"]), "the paper's own gait, evaluated by the same pipeline"))
    analysis["table1"] = _metrics(base)
    # SRB-only (massless legs in the NLP), re-evaluated on the heavy-legged robot.
    unit("srb_only")
    srb = evaluate(geometry(spec, links), gait, task, dataclasses.replace(cfg, leg_dynamics=False))
    n += 1
    # Massless legs: a milligram rod per link (MuJoCo needs some mass on a moving body).
    light = dataclasses.replace(geometry(spec, links), link_masses=(1e-6, 1e-6, 1e-6), inertia="rod")
    massless = evaluate(light, gait, task, dataclasses.replace(cfg, leg_dynamics=False))
    n += 1
    cmp = {"srb_on_heavy_legs": _metrics(srb), "srb_on_massless_legs": _metrics(massless), "leg_dynamics": _metrics(best)}
    if "cot" in massless and "cot" in srb:
        cmp["cot_increase_heavy_vs_massless"] = srb["cot"]["final"] / massless["cot"]["final"] - 1.0
    analysis["srb_vs_legs"] = cmp
    controls.append(_row("srb_only", "SRB with massless legs (paper ref. [10]), re-evaluated on the heavy legs", 2,
                         {"eps_nlp_N": _metrics(srb).get("eps_nlp_N"), "eps_nlp_legs_N": best["eps"]["nlp"]["norm"]
                          if "eps" in best else None, "cot_final": _metrics(srb).get("cot_final"),
                          "cot_massless": _metrics(massless).get("cot_nlp"), "feasible": srb["feasible"]},
                         bool("eps" in srb and "eps" in best and best["eps"]["nlp"]["norm"] < srb["eps"]["nlp"]["norm"]),
                         "target_met when the dummy legs leave a smaller residual than massless legs"))
    # High step: the same design with a higher swing (obstacle clearance).
    unit("high_step")
    high = task_of(spec, swing_height=spec.evidence.high_step_swing_height_m)
    hs = evaluate(geometry(spec, links), gait, high, cfg)
    hs0 = evaluate(geometry(spec, l0), g0, high, cfg)
    n += 2
    analysis["high_step"] = {"swing_height_m": spec.evidence.high_step_swing_height_m, "best_design": _metrics(hs),
                             "table1": _metrics(hs0)}
    controls.append(_row("high_step", f"swing height {spec.evidence.high_step_swing_height_m} m (best design and "
                         "Table 1 re-evaluated)", 2,
                         {"best_" + k: v for k, v in _metrics(hs).items()} | {"table1_" + k: v for k, v in _metrics(hs0).items()},
                         bool(hs["feasible"] or hs0["feasible"]),
                         "not re-optimised; a calf and thigh of unequal length cannot fold the foot as close to the hip"))
    # Table 1's inertias vs the ones a slender rod of that mass and length has.
    unit("rod_inertia")
    rod = evaluate(dataclasses.replace(geometry(spec, links), inertia="rod"), gait, task, cfg)
    n += 1
    analysis["rod_inertia"] = _metrics(rod)
    controls.append(_row("rod_inertia", "link inertias of slender rods instead of Table 1's", 1, _metrics(rod), None,
                         "papers README: Table 1's inertias are 10-1000x a slender link's"))
    # Ablation of the residual iteration (the paper's single NLP pass).
    unit("no_residual_iteration")
    single = evaluate(geometry(spec, links), gait, task, dataclasses.replace(cfg, residual_iterations=0))
    n += 1
    ms = _metrics(single)
    if "eps_qp_N" in ms:
        ms["eps_ratio"] = ms["eps_nlp_N"] / max(ms["eps_qp_N"], 1e-12)
    controls.append(_row("no_residual_iteration", "the paper's single NLP pass (no re-solve with the legs' true wrench)",
                         1, ms, bool("eps_ratio" in ms and ms["eps_ratio"] >= 100), "target: eps_QP 100x below eps_NLP"))
    if ctx.is_cancelled():
        raise Cancelled()
    ctx.progress(done + n, total, {"phase": "analysis", "step": "controls"})
    return controls, analysis, n


def _robustness(spec, geom, ref, task, phys, ctx, done, total):
    cases = []
    steps = 0
    for i, (name, label, over) in enumerate(ROBUSTNESS_CASES):
        if ctx.is_cancelled():
            raise Cancelled()
        p = _physics(spec, geom, ref, task, **over)
        steps += p["steps"]
        s = _physics_summary(p, phys["cot"] if phys else 0.0, task.speed)
        cases.append({"name": name, "label": label, "target_met": s["target_met"],
                      "metrics": {"stays_up": s["stays_up"], "speed_m_s": s["speed_m_s"], "mean_height_m": s["mean_height_m"],
                                  "cot": s["cot"], "periods_completed": s["periods_completed"],
                                  "drift_angle_rad": s["drift_per_period"].get("angle_rad")}})
        ctx.progress(done + i + 1, total, {"phase": "robustness", "case": name, "stays_up": s["stays_up"]})
    spread = {}
    for k in ("speed_m_s", "mean_height_m", "cot"):
        vals = [c["metrics"][k] for c in cases]
        spread[k] = {"min": float(min(vals)), "max": float(max(vals)), "nominal": phys[k] if phys else None}
    return {"target": f"up for {spec.physics.periods} periods in MuJoCo with the realised speed within "
                      f"{int(SPEED_TOL * 100)} % of V",
            "cases": cases, "met": sum(bool(c["target_met"]) for c in cases), "total": len(cases), "spread": spread,
            "sim_steps": steps}


def _summary(spec, best, gait, links, geom, phys, phys_other, controls, analysis, robustness, st, wall, done):
    s: dict[str, Any] = {"kind": "energy", "robot": spec.robot, "seed": spec.seed,
                         "task": spec.task.model_dump(), "family": spec.gait.family,
                         "gait": _gait_summary(gait), "links_m": list(links),
                         "link_masses_kg": geom.masses().tolist(), "total_mass_kg": geom.total_mass,
                         "inertia": geom.inertia, "feasible": best["feasible"], "failed": best["failed"],
                         "J": best["fitness"]}
    if "cot" in best:
        s["cot"] = dict(best["cot"]) | {"physics": phys["cot"] if phys else None}
        s["objective"] = {"J": best["fitness"], "cot": best["objective_terms"]["cot"],
                          "jerk_term_N_s": best["jerk_term_N_s"], "jerk_weight_s": spec.model.jerk_weight}
        s["eps"] = best["eps"]
        s["eps_ratio_nlp_over_qp"] = best["eps"]["nlp"]["norm"] / max(best["eps"]["qp"]["norm"], 1e-12)
        s["periodicity_error"] = best["periodicity_error"]
        s["periodicity"] = best["periodicity"]
        s["periodicity_tolerance"] = PERIODICITY_TOL
        s["nlp_forward_periodicity_error"] = best.get("nlp_forward_periodicity_error")
        s["nlp"] = {k: v for k, v in best["nlp"].items() if k != "seconds"}
    s["physics"] = phys
    s["physics_other_feedback"] = phys_other
    if st is not None:
        s["search"] = {"optimizer": "ga", "population": spec.search.population, "generations": spec.search.generations,
                       "evaluations": st["evaluations"], "best_J": st["best"]["row"]["fitness"],
                       "stop_reason": st["stop_reason"], "generations_run": st["generations_run"]}
    s["analysis"] = analysis
    s["controls"] = controls
    if robustness is not None:
        s["robustness"] = robustness
    s["timing"] = {"wall_s": wall, "evaluations": done}
    if "nlp" in s:  # measured times live under timing: the rest is the same for the same spec and seed
        s["timing"]["fitness_eval_s"] = best["timings_s"] | {"nlp_solver": best["nlp"].get("seconds")}
    return s


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

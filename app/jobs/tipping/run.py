"""Job kind ``tipping``: sideline tipping judgment and recovery of a heavy-duty hexapod
(paper 002, Zhang et al. 2024): FASM every control step from the simulated contact forces,
judgment at 20 deg with a time-to-tip estimate, one swing leg caught onto the optimal
foothold, QP foot forces with friction and FASM cones; each scenario is run with and
without recovery, optionally swept over tilt directions x both tripods."""

from __future__ import annotations

import time

import numpy as np

from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.tipping.spec import TippingSpec
from app.jobs.tipping.evidence import CONVERGENCE_TOL, Setup, convergence_row, outcome, run_evidence, simulate
from app.jobs.tipping.scenario import TiltScenario, first_catch, run_summary

# -- runs -------------------------------------------------------------------------------------

def _setup(spec: TippingSpec, recovery: bool, scenario=None) -> Setup:
    sc = scenario if scenario is not None else spec.scenario.build()
    return Setup(sc, spec.controller(recovery), spec.duration(), spec.geometry(), spec.sim.friction)


def _trace_out(tr: dict) -> dict[str, np.ndarray]:
    out = dict(tr)
    out["stance"] = tr["stance"].astype(bool)
    return out


def run(spec: TippingSpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    ckpt = ctx.load_checkpoint() or {}
    rows: list[dict] = ckpt.get("rows", [])
    units: dict = ckpt.get("evidence", {})
    wall_before = ckpt.get("wall_s", 0.0)
    total = spec.evaluations_budget
    thr = spec.detector.threshold_deg
    done = [0]

    def tick(info: dict) -> None:
        """Before every simulation: stop on cancel, report how far the budget is spent."""
        if ctx.is_cancelled():
            raise Cancelled()
        ctx.progress(done[0], total, info)
        done[0] += 1

    def save() -> None:
        ctx.save_checkpoint({"rows": rows, "evidence": units, "wall_s": wall_before + time.perf_counter() - t0})

    tick({"run": "no_recovery"})
    base = simulate(_setup(spec, False), record_qpos=True)
    runs = {"no_recovery": base}
    if spec.recovery.enabled:
        tick({"run": "recovery", "no_recovery_tipped": base["tipped"]})
        runs["recovery"] = simulate(_setup(spec, True), record_qpos=True)
    sim_steps = sum(r["sim_steps"] for r in runs.values())

    evidence: dict = {}
    if spec.recovery.enabled:
        # Units already done before a restart come from the checkpoint; the rest count here.
        done[0] += len(units)

        def before(key: str) -> None:
            tick({"evidence": key})

        def on_done(key: str, value: dict) -> None:
            units[key] = value
            save()

        evidence = run_evidence(_setup(spec, True), outcome(runs["recovery"]), outcome(base), spec.evidence.plan(),
                                before=before, cache=units, on_done=on_done)

    sweep = None
    if spec.sweep.enabled:
        s = spec.scenario
        cases = [(360.0 * k / spec.sweep.directions, tuple(st), rec)
                 for k in range(spec.sweep.directions) for st in spec.sweep.stances for rec in (False, True)]
        done[0] += len(rows)
        for i, (psi, st, rec) in enumerate(cases):
            if i < len(rows):
                continue  # done before a restart
            tick({"downhill_deg": psi, "stance": "".join(map(str, st)), "recovery": rec})
            sc = TiltScenario(downhill_deg=psi, stance=st, rate_deg_s=s.rate_deg_s, settle_s=s.settle_s,
                              max_tilt_deg=s.max_tilt_deg, hold_s=s.hold_s)
            r = simulate(_setup(spec, rec, sc))
            first = first_catch(r["adjustments"])
            rows.append({"run": i, "downhill_deg": psi, "stance": "".join(map(str, st)), "recovery": int(rec),
                         "tipped": int(r["tipped"]), "tipped_at_s": r["tipped_at_s"],
                         "static_tip_deg": r["static_tip_deg"],
                         "detect_time_s": first["detect_time_s"] if first else None,
                         "edge": first["edge"] if first else "", "leg": first["leg"] if first else 0,
                         "margin_after_deg": first["margin_after_landing_deg"] if first else None,
                         "final_margin_deg": float(r["trace"]["fasm_deg"][-1]), "sim_steps": r["sim_steps"]})
            save()
        sweep = sweep_table(rows, spec.sweep.directions)
        sim_steps += sum(r["sim_steps"] for r in rows)
    ctx.progress(done[0], total, {"done": True})

    wall = wall_before + time.perf_counter() - t0
    summaries = {name: run_summary(r, thr) for name, r in runs.items()}
    sc = spec.scenario
    scenario = sc.model_dump() | ({"downhill_deg": sc.resolved_downhill()} if sc.type == "tilt" else {})
    summary = {
        "kind": "tipping", "robot": spec.robot, "seed": spec.seed, "scenario": scenario,
        "threshold_deg": thr, "target_margin_deg": spec.evidence.target_margin_deg,
        "runs": summaries,
        "recovered": (spec.recovery.enabled and summaries["no_recovery"]["tipped"]
                      and not summaries["recovery"]["tipped"]),
        "timing": {"wall_s": wall, "sim_steps": sim_steps, "sim_steps_per_s": sim_steps / max(wall, 1e-9),
                   "control_ms_mean": float(np.mean([r["control_ms_mean"] for r in runs.values()])),
                   "control_ms_p95": float(np.max([r["control_ms_p95"] for r in runs.values()]))},
    }
    if "recovery" in summaries:
        rs = summaries["recovery"]
        for k in ("detection_time_s", "tipping_edge", "adjustment_leg", "foothold_body_m", "adjustment_time_s",
                  "time_to_tip_s", "margin_before_landing_deg", "margin_after_landing_deg", "max_slip_m"):
            summary[k] = rs.get(k)
        summary["swing_s"] = (first_catch(rs["adjustments"]) or {}).get("swing_s")
    summary.update(evidence)  # controls, robustness, band
    rob = evidence.get("robustness")
    if rob:
        half = next(c for c in rob["cases"] if c["name"] == "dt_half")
        summary["convergence"] = {"timestep_s": spec.sim.timestep_s, "tolerance": CONVERGENCE_TOL,
                                  "step_halved": convergence_row(outcome(runs["recovery"]), half["metrics"])}
    if sweep is not None:
        summary["sweep"] = sweep
    history = rows if rows else [{"run": i, "name": n, "tipped": int(r["tipped"]),
                                  "min_margin_deg": summaries[n]["min_margin_deg"]} for i, (n, r) in enumerate(runs.items())]
    traces = {name: _trace_out(r["trace"]) for name, r in runs.items()}
    return JobResult(summary=summary, history=history, traces=traces, model_xml=base["model_xml"],
                     evaluations=done[0], sim_steps=sim_steps)


def sweep_table(rows: list[dict], directions: int) -> dict:
    """Per downhill direction, over the swept tripods: ``success_rate`` = share of recovery
    runs that end upright; ``tip_rate_without_recovery``; ``recovered_rate`` = share where
    the robot tips without recovery and stays up with it (recovery made the difference)."""
    dirs = [360.0 * k / directions for k in range(directions)]
    success, tip_without, recovered = [], [], []
    for psi in dirs:
        base = {r["stance"]: r for r in rows if r["downhill_deg"] == psi and not r["recovery"]}
        rec = {r["stance"]: r for r in rows if r["downhill_deg"] == psi and r["recovery"]}
        st = sorted(set(base) & set(rec))
        success.append(float(np.mean([not rec[s]["tipped"] for s in st])) if st else None)
        tip_without.append(float(np.mean([base[s]["tipped"] for s in st])) if st else None)
        recovered.append(float(np.mean([base[s]["tipped"] and not rec[s]["tipped"] for s in st])) if st else None)
    done = [s for s in success if s is not None]
    return {"directions_deg": dirs, "success_rate": success, "tip_rate_without_recovery": tip_without,
            "recovered_rate": recovered, "overall_success_rate": float(np.mean(done)) if done else None}

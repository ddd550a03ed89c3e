"""Job kind ``tipping``: sideline tipping judgment and recovery of a heavy-duty hexapod
(paper 002, Zhang et al. 2024): FASM every control step from the simulated contact forces,
judgment at 20 deg with a time-to-tip estimate, one swing leg caught onto the optimal
foothold, QP foot forces with friction and FASM cones; each scenario is run with and
without recovery, optionally swept over tilt directions x both tripods.

The job is a row of phases (``TippingSpec.phase_sizes``), one simulation per unit of
progress: the runs a user reads, then the controls, the robustness re-runs and the
survivable tilt band, then the direction sweep."""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np

from app.jobs.base import JobResult, RunContext
from app.jobs.evidence import PhaseContext, Phases, Robustness
from app.jobs.tipping.evidence import (CONVERGENCE_TOL, EvidencePlan, Setup, Units, band, control_rows,
                                       convergence_row, outcome, robustness, simulate)
from app.jobs.tipping.scenario import TiltScenario, first_catch, run_summary
from app.jobs.tipping.spec import TippingSpec


def _setup(spec: TippingSpec, recovery: bool, scenario=None) -> Setup:
    sc = scenario if scenario is not None else spec.scenario.build()
    return Setup(sc, spec.controller(recovery), spec.duration(), spec.geometry(), spec.sim.friction)


def _trace_out(tr: dict) -> dict[str, np.ndarray]:
    out = dict(tr)
    out["stance"] = tr["stance"].astype(bool)
    return out


@dataclasses.dataclass
class _Job:
    """What one attempt at a job carries from step to step."""

    spec: TippingSpec
    phases: Phases
    started: float  # perf_counter at this attempt's start
    wall_before: float  # wall time of the attempts before a restart
    plan: EvidencePlan
    runs: dict[str, dict] = dataclasses.field(default_factory=dict)  # the simulations a user reads, by name
    units: dict[str, Units] = dataclasses.field(default_factory=dict)  # each evidence phase's simulations
    evidence: dict = dataclasses.field(default_factory=dict)  # controls, robustness, band as the summary holds them
    robustness: Robustness | None = None
    rows: list[dict] = dataclasses.field(default_factory=list)  # the direction sweep's runs

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    @property
    def answer(self) -> Setup:
        return _setup(self.spec, True)

    @property
    def evaluations(self) -> int:
        return len(self.runs) + sum(len(u.done) for u in self.units.values()) + len(self.rows)

    @property
    def sim_steps(self) -> int:
        return sum(r["sim_steps"] for r in self.runs.values()) + sum(r["sim_steps"] for r in self.rows)


# -- the steps ----------------------------------------------------------------------------------

def _start(spec: TippingSpec, ctx: RunContext) -> _Job:
    started = time.perf_counter()
    phases = Phases(ctx, spec.phase_sizes())
    # Each phase's checkpoint entry records the job's wall time when it was written; a
    # resumed job's clock starts from the latest.
    wall = max((e.get("wall_s", 0.0) for e in phases.state.values() if isinstance(e, dict)), default=0.0)
    return _Job(spec, phases, started, wall, spec.evidence.plan())


def _simulate_runs(job: _Job) -> None:
    """The scenario without recovery, and (recovery on) with it: the baseline and the answer.
    Not checkpointed: a resumed job needs their traces, so it runs them again."""
    pc = job.phases.context("runs")
    pc.check()
    names = ("no_recovery", "recovery") if job.spec.recovery.enabled else ("no_recovery",)
    for name in names:
        job.runs[name] = r = simulate(_setup(job.spec, name == "recovery"), record_qpos=True)
        pc.tick(1, {"run": name, "tipped": r["tipped"]})


def _resumed(pc: PhaseContext, n: int) -> None:
    if n:
        pc.tick(n, {"resumed": n})


def _unit_done(job: _Job, pc: PhaseContext, units: Units, key: str, value: dict) -> None:
    # saved before it is counted: a cancel or a kill after this simulation keeps it
    pc.save_checkpoint({"units": units.done, "wall_s": job.wall()})
    pc.tick(1, {"evidence": key})


def _units(job: _Job, phase: str) -> Units:
    """An evidence phase's simulations, those finished before a restart included."""
    pc = job.phases.context(phase)
    units = Units((pc.load_checkpoint() or {}).get("units", {}))
    units.on_done = functools.partial(_unit_done, job, pc, units)
    _resumed(pc, len(units.done))
    job.units[phase] = units
    return units


def _controls(job: _Job) -> None:
    baseline = outcome(job.runs["no_recovery"])
    job.evidence["controls"] = control_rows(job.answer, baseline, job.plan.target, _units(job, "controls"))


def _robustness(job: _Job) -> None:
    nominal = outcome(job.runs["recovery"])
    job.robustness = robustness(job.answer, nominal, job.plan.target, _units(job, "robustness"))
    job.evidence["robustness"] = job.robustness.to_json()


def _band(job: _Job) -> None:
    job.evidence["band"] = band(job.answer, job.plan, _units(job, "band"))


def _sweep_cases(spec: TippingSpec) -> list[tuple[float, tuple[int, ...], bool]]:
    return [(360.0 * k / spec.sweep.directions, tuple(st), rec)
            for k in range(spec.sweep.directions) for st in spec.sweep.stances for rec in (False, True)]


def sweep_run(spec: TippingSpec, i: int, psi: float, stance: tuple[int, ...], recovery: bool) -> dict:
    """One run of the direction sweep: the spec's platform motion turned toward ``psi``, the
    tripod ``stance`` in stance, with or without recovery; its row (``i``: its index)."""
    s = spec.scenario
    sc = TiltScenario(downhill_deg=psi, stance=stance, rate_deg_s=s.rate_deg_s, settle_s=s.settle_s,
                      max_tilt_deg=s.max_tilt_deg, hold_s=s.hold_s)
    return _sweep_row(i, psi, stance, recovery, simulate(_setup(spec, recovery, sc)))


def _sweep_row(i: int, psi: float, stance: tuple[int, ...], recovery: bool, r: dict) -> dict:
    first = first_catch(r["adjustments"])
    return {"run": i, "downhill_deg": psi, "stance": "".join(map(str, stance)), "recovery": int(recovery),
            "tipped": int(r["tipped"]), "tipped_at_s": r["tipped_at_s"], "static_tip_deg": r["static_tip_deg"],
            "detect_time_s": first["detect_time_s"] if first else None,
            "edge": first["edge"] if first else "", "leg": first["leg"] if first else 0,
            "margin_after_deg": first["margin_after_landing_deg"] if first else None,
            "final_margin_deg": float(r["trace"]["fasm_deg"][-1]), "sim_steps": r["sim_steps"]}


def _sweep(job: _Job) -> None:
    """Every downhill direction x tripod, without and with recovery."""
    pc = job.phases.context("sweep")
    job.rows = rows = list((pc.load_checkpoint() or {}).get("rows", []))
    _resumed(pc, len(rows))
    for i, (psi, st, rec) in enumerate(_sweep_cases(job.spec)[len(rows):], start=len(rows)):
        rows.append(sweep_run(job.spec, i, psi, st, rec))
        pc.save_checkpoint({"rows": rows, "wall_s": job.wall()})
        pc.tick(1, {"downhill_deg": psi, "stance": "".join(map(str, st)), "recovery": rec})


ANSWER_KEYS = ("detection_time_s", "tipping_edge", "adjustment_leg", "foothold_body_m", "adjustment_time_s",
               "time_to_tip_s", "margin_before_landing_deg", "margin_after_landing_deg", "max_slip_m")


def _timing(job: _Job) -> dict:
    wall, steps = job.wall(), job.sim_steps
    return {"wall_s": wall, "sim_steps": steps, "sim_steps_per_s": steps / max(wall, 1e-9),
            "control_ms_mean": float(np.mean([r["control_ms_mean"] for r in job.runs.values()])),
            "control_ms_p95": float(np.max([r["control_ms_p95"] for r in job.runs.values()]))}


def _summary(job: _Job) -> dict:
    spec = job.spec
    thr = spec.detector.threshold_deg
    summaries = {name: run_summary(r, thr) for name, r in job.runs.items()}
    sc = spec.scenario
    scenario = sc.model_dump() | ({"downhill_deg": sc.resolved_downhill()} if sc.type == "tilt" else {})
    summary = {
        "kind": "tipping", "robot": spec.robot, "seed": spec.seed, "scenario": scenario,
        "threshold_deg": thr, "target_margin_deg": spec.evidence.target_margin_deg,
        "runs": summaries,
        "recovered": (spec.recovery.enabled and summaries["no_recovery"]["tipped"]
                      and not summaries["recovery"]["tipped"]),
        "timing": _timing(job),
    }
    if "recovery" in summaries:
        rs = summaries["recovery"]
        summary.update({k: rs.get(k) for k in ANSWER_KEYS})
        summary["swing_s"] = (first_catch(rs["adjustments"]) or {}).get("swing_s")
    summary.update(job.evidence)
    if job.robustness is not None:
        half = next(c for c in job.robustness.cases if c.name == "dt_half")
        summary["convergence"] = {"timestep_s": spec.sim.timestep_s, "tolerance": CONVERGENCE_TOL,
                                  "step_halved": convergence_row(outcome(job.runs["recovery"]), half.metrics)}
    if spec.sweep.enabled:
        summary["sweep"] = sweep_table(job.rows, spec.sweep.directions)
    return summary


def _history(job: _Job, summary: dict) -> list[dict]:
    """The sweep's runs when it ran, else one row per run a user reads."""
    if job.rows:
        return job.rows
    return [{"run": i, "name": n, "tipped": int(r["tipped"]), "min_margin_deg": summary["runs"][n]["min_margin_deg"]}
            for i, (n, r) in enumerate(job.runs.items())]


def run(spec: TippingSpec, ctx: RunContext) -> JobResult:
    job = _start(spec, ctx)
    _simulate_runs(job)
    for phase, step in (("controls", _controls), ("robustness", _robustness), ("band", _band), ("sweep", _sweep)):
        if phase in job.phases.sizes:
            step(job)
    job.phases.finish()
    summary = _summary(job)
    return JobResult(summary=summary, history=_history(job, summary),
                     traces={name: _trace_out(r["trace"]) for name, r in job.runs.items()},
                     model_xml=job.runs["no_recovery"]["model_xml"], evaluations=job.evaluations,
                     sim_steps=job.sim_steps)


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

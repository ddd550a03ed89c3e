"""Job kind ``tipping``: sideline tipping judgment and recovery of a heavy-duty hexapod
(paper 002, Zhang et al. 2024): FASM every control step from the simulated contact forces,
judgment at 20 deg with a time-to-tip estimate, one swing leg caught onto the optimal
foothold, QP foot forces with friction and FASM cones; each scenario is run with and
without recovery, optionally swept over tilt directions x both tripods."""

from __future__ import annotations

import time
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from app.jobs.base import Cancelled, JobResult, RunContext
from app.robots.heavy_hexapod import HEAVY, TRIPODS
from app.stability.scenario import (CliffScenario, ControllerConfig, TiltScenario, first_catch, paper_direction,
                                    run_cliff, run_summary, run_tilt)

Strict = ConfigDict(extra="forbid")
Tripod = list[Annotated[int, Field(ge=1, le=6)]]


def _check_tripod(v: list[int]) -> list[int]:
    if tuple(sorted(v)) not in TRIPODS:
        raise ValueError(f"must be a tripod, [1, 3, 5] or [2, 4, 6]; got {v}")
    return sorted(v)


class TiltIn(BaseModel):
    """Tilting platform (Sec. 5.2). Direction either as the paper names it (``axis`` +
    ``direction``; ccw as seen from the axis's negative end: y ccw = climbing, the robot tips
    backward; x ccw = it tips to its left) or as ``downhill_deg`` (0 = the robot's front
    goes down, 90 = its left side), not both."""

    model_config = Strict
    type: Literal["tilt"] = "tilt"
    axis: Literal["x", "y"] | None = None
    direction: Literal["ccw", "cw"] | None = None
    downhill_deg: float | None = Field(None, ge=0.0, lt=360.0)
    rate_deg_s: float = Field(3.0, gt=0.0, le=20.0)
    stance: Tripod = Field(default_factory=lambda: [1, 3, 5])
    settle_s: float = Field(3.0, ge=0.5, le=20.0)
    max_tilt_deg: float | None = Field(None, gt=0.0, le=60.0)
    overshoot_deg: float = Field(4.0, ge=0.0, le=15.0)
    hold_s: float = Field(6.0, ge=0.0, le=60.0)  # runs last until the final tilt has been held this long

    @field_validator("stance")
    @classmethod
    def _tripod(cls, v: list[int]) -> list[int]:
        return _check_tripod(v)

    @model_validator(mode="after")
    def _one_direction(self):
        if self.downhill_deg is not None and (self.axis is not None or self.direction is not None):
            raise ValueError("give either axis + direction or downhill_deg, not both")
        return self

    def resolved_downhill(self) -> float:
        if self.downhill_deg is not None:
            return float(self.downhill_deg)
        return paper_direction(self.axis or "y", self.direction or "ccw")

    def build(self) -> TiltScenario:
        return TiltScenario(downhill_deg=self.resolved_downhill(), stance=tuple(self.stance), rate_deg_s=self.rate_deg_s,
                            settle_s=self.settle_s, max_tilt_deg=self.max_tilt_deg, overshoot_deg=self.overshoot_deg,
                            hold_s=self.hold_s)


class CliffIn(BaseModel):
    """Tripod walking from flat ground onto a unilateral cliff (Sec. 5.1)."""

    model_config = Strict
    type: Literal["cliff"] = "cliff"
    side: Literal["left", "right"] = "right"
    cliff_x: float = Field(4.5, ge=2.6, le=20.0)
    duty_factor: float = Field(14.0 / 24.0, gt=0.5, lt=1.0)
    step_m: float = Field(0.5, gt=0.0, le=1.2)
    period_s: float = Field(6.0, ge=2.0, le=20.0)
    stand_s: float = Field(3.0, ge=0.5, le=10.0)

    def build(self) -> CliffScenario:
        return CliffScenario(side=self.side, cliff_x=self.cliff_x, duty_factor=self.duty_factor, step_m=self.step_m,
                             period_s=self.period_s, stand_s=self.stand_s)


class TippingDetector(BaseModel):
    model_config = Strict
    threshold_deg: float = Field(20.0, gt=0.0, le=60.0)  # xi_f, Sec. 3
    kappa: float = Field(0.8, gt=0.0, lt=1.0)  # Eq. 15


class TippingRecovery(BaseModel):
    model_config = Strict
    enabled: bool = True
    safety_margin: float = Field(0.9, gt=0.0, lt=1.0)  # rho, Eq. 11-13
    cone_lambda: float = Field(0.9, gt=0.0, lt=1.0)  # lambda, Eq. 21
    qp: bool = True
    mu_qp: float = Field(1.2, gt=0.0, le=2.0)
    swing_min_s: float = Field(0.4, gt=0.0, le=5.0)
    swing_max_s: float = Field(1.5, gt=0.0, le=5.0)
    clearance_m: float = Field(0.25, ge=0.0, le=0.8)
    max_adjustments: int = Field(2, ge=1, le=3)
    # 0: the QP forces act as joint feed-forward; > 0 (e.g. 2.5e-6 m/s per N) the stance
    # feet also press until their normal forces match the QP's internal-force share.
    force_tracking_gain: float = Field(0.0, ge=0.0, le=1e-5)

    @model_validator(mode="after")
    def _swing_order(self):
        if self.swing_min_s > self.swing_max_s:
            raise ValueError(f"swing_min_s {self.swing_min_s} exceeds swing_max_s {self.swing_max_s}")
        return self


class TippingSim(BaseModel):
    model_config = Strict
    # None: 25 s tilt, 32 s cliff. A tilt run is extended until the platform has held its
    # final tilt for scenario.hold_s.
    duration_s: float | None = Field(None, gt=1.0, le=120.0)
    friction: float = Field(1.5, gt=0.1, le=3.0)  # the paper assumes feet never slip
    control_dt: float = Field(0.02, ge=0.002, le=0.05)

    @field_validator("control_dt")
    @classmethod
    def _multiple_of_timestep(cls, v: float) -> float:
        k = v / HEAVY.timestep
        if abs(k - round(k)) > 1e-6:
            raise ValueError(f"must be a multiple of the physics step {HEAVY.timestep} s")
        return v


class TippingSweep(BaseModel):
    model_config = Strict
    enabled: bool = False
    directions: int = Field(12, ge=1, le=36)
    stances: list[Tripod] = Field(default_factory=lambda: [[1, 3, 5], [2, 4, 6]], min_length=1, max_length=2)

    @field_validator("stances")
    @classmethod
    def _tripods(cls, v):
        return [_check_tripod(s) for s in v]


class TippingSpec(BaseModel):
    model_config = Strict
    kind: Literal["tipping"] = "tipping"
    robot: Literal["heavy_hexapod"] = "heavy_hexapod"
    scenario: Annotated[Union[TiltIn, CliffIn], Field(discriminator="type")] = Field(default_factory=TiltIn)
    detector: TippingDetector = Field(default_factory=TippingDetector)
    recovery: TippingRecovery = Field(default_factory=TippingRecovery)
    sim: TippingSim = Field(default_factory=TippingSim)
    sweep: TippingSweep = Field(default_factory=TippingSweep)
    seed: int = Field(0, ge=0, le=2**32 - 1)  # recorded; the scenarios draw nothing at random

    @model_validator(mode="after")
    def _sweep_needs_tilt(self):
        if self.sweep.enabled and self.scenario.type != "tilt":
            raise ValueError("sweep: the direction sweep turns the tilting platform; scenario.type must be 'tilt'")
        return self

    @property
    def evaluations_budget(self) -> int:
        n = 2
        if self.sweep.enabled:
            n += 2 * self.sweep.directions * len(self.sweep.stances)
        return n

    def duration(self) -> float:
        if self.sim.duration_s is not None:
            return self.sim.duration_s
        return 25.0 if self.scenario.type == "tilt" else 32.0

    def controller(self, recovery: bool) -> ControllerConfig:
        r = self.recovery
        return ControllerConfig(recovery=recovery, threshold_deg=self.detector.threshold_deg, kappa=self.detector.kappa,
                                rho=r.safety_margin, lam=r.cone_lambda, mu=r.mu_qp, swing_min_s=r.swing_min_s,
                                swing_max_s=r.swing_max_s, clearance_m=r.clearance_m, qp=r.qp,
                                control_dt=self.sim.control_dt, max_adjustments=r.max_adjustments,
                                force_gain=r.force_tracking_gain)


Spec = TippingSpec


# -- runs -------------------------------------------------------------------------------------

def _simulate(spec: TippingSpec, recovery: bool, scenario=None, record_qpos: bool = True) -> dict:
    sc = scenario if scenario is not None else spec.scenario.build()
    cfg = spec.controller(recovery)
    if isinstance(sc, TiltScenario):
        return run_tilt(sc, cfg, spec.duration(), friction=spec.sim.friction, record_qpos=record_qpos)
    return run_cliff(sc, cfg, spec.duration(), friction=spec.sim.friction, record_qpos=record_qpos)


def _trace_out(tr: dict) -> dict[str, np.ndarray]:
    out = dict(tr)
    out["stance"] = tr["stance"].astype(bool)
    return out


def run(spec: TippingSpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    ckpt = ctx.load_checkpoint() or {}
    rows: list[dict] = ckpt.get("rows", [])
    wall_before = ckpt.get("wall_s", 0.0)
    total = spec.evaluations_budget
    thr = spec.detector.threshold_deg

    if ctx.is_cancelled():
        raise Cancelled()
    base = _simulate(spec, recovery=False)
    ctx.progress(1, total, {"run": "no_recovery", "tipped": base["tipped"]})
    runs = {"no_recovery": base}
    if spec.recovery.enabled:
        runs["recovery"] = _simulate(spec, recovery=True)
    ctx.progress(2, total, {"run": "recovery", "tipped": runs.get("recovery", base)["tipped"]})
    sim_steps = sum(r["sim_steps"] for r in runs.values())

    sweep = None
    if spec.sweep.enabled:
        s = spec.scenario
        cases = [(360.0 * k / spec.sweep.directions, tuple(st), rec)
                 for k in range(spec.sweep.directions) for st in spec.sweep.stances for rec in (False, True)]
        for i, (psi, st, rec) in enumerate(cases):
            if i < len(rows):
                continue  # done before a restart
            if ctx.is_cancelled():
                raise Cancelled()
            sc = TiltScenario(downhill_deg=psi, stance=st, rate_deg_s=s.rate_deg_s, settle_s=s.settle_s,
                              max_tilt_deg=s.max_tilt_deg, overshoot_deg=s.overshoot_deg, hold_s=s.hold_s)
            r = _simulate(spec, rec, sc, record_qpos=False)
            first = first_catch(r["adjustments"])
            rows.append({"run": i, "downhill_deg": psi, "stance": "".join(map(str, st)), "recovery": int(rec),
                         "tipped": int(r["tipped"]), "tipped_at_s": r["tipped_at_s"],
                         "static_tip_deg": r["static_tip_deg"],
                         "detect_time_s": first["detect_time_s"] if first else None,
                         "edge": first["edge"] if first else "", "leg": first["leg"] if first else 0,
                         "margin_after_deg": first["margin_after_landing_deg"] if first else None,
                         "final_margin_deg": float(r["trace"]["fasm_deg"][-1]), "sim_steps": r["sim_steps"]})
            wall = wall_before + time.perf_counter() - t0
            ctx.save_checkpoint({"rows": rows, "wall_s": wall})
            ctx.progress(3 + i, total, {"downhill_deg": psi, "stance": rows[-1]["stance"], "recovery": rec,
                                        "tipped": bool(r["tipped"])})
        sweep = sweep_table(rows, spec.sweep.directions)
        sim_steps += sum(r["sim_steps"] for r in rows)

    wall = wall_before + time.perf_counter() - t0
    summaries = {name: run_summary(r, thr) for name, r in runs.items()}
    sc = spec.scenario
    scenario = sc.model_dump() | ({"downhill_deg": sc.resolved_downhill()} if sc.type == "tilt" else {})
    summary = {
        "kind": "tipping", "robot": spec.robot, "seed": spec.seed, "scenario": scenario,
        "threshold_deg": thr,
        "runs": summaries,
        "recovered": (spec.recovery.enabled and summaries["no_recovery"]["tipped"]
                      and not summaries["recovery"]["tipped"]),
        "timing": {"wall_s": wall, "sim_steps": sim_steps, "sim_steps_per_s": sim_steps / max(wall, 1e-9),
                   "control_ms_mean": float(np.mean([s["control_ms_mean"] for s in summaries.values()])),
                   "control_ms_p95": float(np.max([s["control_ms_p95"] for s in summaries.values()]))},
    }
    if "recovery" in summaries:
        rs = summaries["recovery"]
        for k in ("detection_time_s", "tipping_edge", "adjustment_leg", "foothold_body_m", "adjustment_time_s",
                  "time_to_tip_s", "margin_before_landing_deg", "margin_after_landing_deg"):
            summary[k] = rs.get(k)
    if sweep is not None:
        summary["sweep"] = sweep
    history = rows if rows else [{"run": i, "name": n, "tipped": int(r["tipped"]),
                                  "min_margin_deg": summaries[n]["min_margin_deg"]} for i, (n, r) in enumerate(runs.items())]
    traces = {name: _trace_out(r["trace"]) for name, r in runs.items()}
    return JobResult(summary=summary, history=history, traces=traces, model_xml=base["model_xml"],
                     evaluations=len(runs) + len(rows), sim_steps=sim_steps)


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


def plots(result: JobResult, out):
    from app.stability import plots as P

    files = P.margin_timeline(result.traces, result.summary, out)
    files += P.foot_forces(result.traces, out)
    files += P.tilt(result.traces, out)
    if "sweep" in result.summary:
        files += P.sweep(result.summary["sweep"], out)
    return files

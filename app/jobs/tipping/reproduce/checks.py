"""Issue 12's checks behind docs/tipping.md's findings 2 and 3, its convergence rule and its
robustness paragraph, re-run through ledgers (issue 28): every simulation is a tilt job
(its spec is in the ledger row, as a user would post it), appended to
docs/tipping_<name>.json as it finishes (a re-run skips the runs there); the paragraphs'
numbers are rendered from those files by app/jobs/tipping/reproduce/checks_docs.py.

- friction: the three cases (climbing, descending, lateral; stance 1-3-5 at 40 deg) at each
  friction, recovery with force-controlled stance legs (the QP's forces, the default), with
  position servos (the QP as feed-forward) and without the QP.
- timing: the three cases at each platform rate, recovery with the Eq. 15 swing, with a
  fixed 1.5 s swing, and without recovery (when the margin reaches 0 after the judgment).
- convergence: the recovered answer of each downhill direction at each physics step and
  at its half (the 1 ms runs serve both 2 ms and 1 ms).
- robustness: the job's robustness block of each case (its seven re-runs, and the answer
  they perturb)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field, field_validator

from app.jobs.ledger import Ledger
from app.jobs.tipping.reproduce.checks_docs import (CONVERGENCE_COMMAND, CONVERGENCE_JSON, FRICTION_COMMAND, FRICTION_JSON,
                                          ROBUST_COMMAND, ROBUST_JSON, TIMING_COMMAND, TIMING_JSON, render_convergence,
                                          render_friction, render_robustness, render_timing)
from app.jobs.tipping.evidence import ROBUSTNESS_CASES, outcome, simulate
from app.jobs.tipping.reproduce.reruns import SCIENCE, _load, cliff_evidence
from app.jobs.tipping.run import _setup
from app.jobs.tipping.scenario import first_catch
from app.jobs.tipping.spec import TippingSpec

CASES = {"climbing": 180.0, "descending": 0.0, "lateral": 90.0}  # case -> downhill (deg), stance 1-3-5
# stance modes of the friction check -> the job's recovery section
MODES = {"qp_force": {}, "position_stance": {"stance_control": "position"}, "no_qp": {"qp": False}}
TIMINGS = {"eq15": {}, "fixed": {"swing_timing": "fixed"}, "no_recovery": {"enabled": False}}


def tilt_job(psi: float, tilt: float, rate: float = 10.0, friction: float = 1.5, step_ms: float = 1.0,
             recovery: dict | None = None) -> dict:
    """A tilt job (JSON, as a user posts it) toward downhill ``psi``, stance 1-3-5."""
    return {"kind": "tipping", "scenario": {"type": "tilt", "downhill_deg": float(psi), "rate_deg_s": float(rate),
                                            "max_tilt_deg": float(tilt)},
            "sim": {"friction": float(friction), "timestep_s": step_ms / 1e3}, "recovery": dict(recovery or {})}


def _simulate(job: dict) -> tuple[TippingSpec, dict]:
    spec = TippingSpec.model_validate(job)
    return spec, simulate(_setup(spec, spec.recovery.enabled))


def qp_force_error(r: dict) -> float | None:
    """Largest |mean measured - mean QP force| over the stance feet from 1 s after the
    caught leg lands to the end, in % of the robot's weight (None: no landing, tipped, or
    the QP off)."""
    first = first_catch(r["adjustments"])
    if r["tipped"] or not first or first.get("land_time_s") is None:
        return None
    tr = r["trace"]
    late = tr["time_s"] > first["land_time_s"] + 1.0
    if not late.any():
        return None
    stance = tr["stance"][late][-1]
    if not np.any(tr["qp_f_n"][late]):
        return None  # the QP was off
    err = np.abs(tr["foot_f_n"][late][:, stance].mean(axis=0) - tr["qp_f_n"][late][:, stance].mean(axis=0))
    return float(100.0 * err.max() / (r["mass_kg"] * 9.81))


def foot_loads(r: dict) -> dict[str, float]:
    """Each stance foot's mean vertical force over the last second, % of the weight (legs 1-6)."""
    tr = r["trace"]
    last = tr["time_s"] > tr["time_s"][-1] - 1.0
    stance = tr["stance"][last][-1]
    fz = tr["foot_fz_n"][last].mean(axis=0)
    return {str(i + 1): float(100.0 * fz[i] / (r["mass_kg"] * 9.81)) for i in range(6) if stance[i]}


def friction_run(job: dict) -> dict:
    _, r = _simulate(job)
    return outcome(r) | {"qp_force_error_pct": qp_force_error(r), "stance_load_pct": foot_loads(r)} | _load()


def platform_phase(spec: TippingSpec, t: float | None) -> str | None:
    """Where the platform's motion is at time ``t``: ramping up, at the constant rate,
    ramping down, or holding (scenario.py's trapezoidal profile)."""
    if t is None:
        return None
    sc = spec.scenario
    s, ramp = t - sc.settle_s, min(1.0, sc.max_tilt_deg / sc.rate_deg_s)
    total = sc.max_tilt_deg / sc.rate_deg_s + ramp
    return next(name for name, end in (("at rest", 0.0), ("ramping up", ramp), ("constant rate", total - ramp),
                                       ("ramping down", total), ("holding", np.inf)) if s < end)


def timing_run(job: dict) -> dict:
    """One timing run: its outcome, the platform's phase at the judgment, and (without
    recovery, where no judgment is recorded) when the margin first reaches 0; the renderer
    counts it from the recovery run's judgment."""
    spec, r = _simulate(job)
    out = outcome(r)
    out["platform_at_detection"] = platform_phase(spec, out["detection_time_s"])
    out["kappa"] = spec.detector.kappa
    if not spec.recovery.enabled:
        tr = r["trace"]
        zero = (tr["time_s"] >= spec.scenario.settle_s) & (tr["fasm_deg"] <= 0.0)
        out["margin_zero_s"] = float(tr["time_s"][zero.argmax()]) if zero.any() else None
    return out | _load()


def plain_run(job: dict) -> dict:
    return outcome(_simulate(job)[1]) | _load()


def nominal_run(job: dict) -> dict:
    """The answer the robustness block perturbs, with the platform's tilt when the caught
    leg lands and 0.5 s later (when the margin after landing is read)."""
    _, r = _simulate(job)
    first, tr = first_catch(r["adjustments"]) or {}, r["trace"]
    land = first.get("land_time_s")
    at = (lambda t: float(np.interp(t, tr["time_s"], tr["platform_tilt_deg"])))
    tilts = None if land is None else [at(land), at(land + 0.5)]
    return outcome(r) | {"platform_tilt_at_landing_deg": tilts} | _load()


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


class _Check(BaseModel):
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt (deg)")
    cases: str = Field(",".join(CASES), description="cases (climbing, descending, lateral), comma-separated")

    @field_validator("cases")
    @classmethod
    def _known(cls, v: str) -> str:
        bad = [c for c in (x.strip() for x in v.split(",")) if c and c not in CASES]
        if bad or not v.strip():
            raise ValueError(f"cases must be among {', '.join(CASES)}; got {v!r}")
        return v

    def case_list(self) -> list[str]:
        return [c.strip() for c in self.cases.split(",") if c.strip()]


def _run_plan(p: BaseModel, path: Path | None, experiment: str, command: str,
              plan: list[tuple[str, dict, Callable[[], dict]]], log: Callable[[str], None]) -> dict:
    led = Ledger(path, experiment, command, p.model_dump(mode="json"), SCIENCE, planned=len(plan))
    for name, spec, work in plan:
        led.run(name, spec, 0, work, log)
    return led.data


class FrictionParams(_Check):
    frictions: str = Field("1.5,1.0,0.9,0.8", description="foot-ground friction coefficients, comma-separated")
    json_out: Path | None = Field(Path(FRICTION_JSON), description="the ledger (finished runs are skipped)")

    @field_validator("frictions")
    @classmethod
    def _mu(cls, v: str) -> str:
        if not _floats(v) or any(not 0.1 < m <= 3.0 for m in _floats(v)):
            raise ValueError(f"frictions must be in (0.1, 3]; got {v!r}")
        return v


def friction(p: FrictionParams, log: Callable[[str], None]) -> str:
    """Does the QP's force distribution matter on low friction?"""
    plan = [(f"{mu:g}:{c}:{m}", {"job": job}, lambda job=job: friction_run(job))
            for mu in _floats(p.frictions) for c in p.case_list() for m, rec in MODES.items()
            for job in [tilt_job(CASES[c], p.max_tilt_deg, friction=mu, recovery=rec)]]
    return render_friction([_run_plan(p, p.json_out, "tipping-friction", FRICTION_COMMAND, plan, log)])


class TimingParams(_Check):
    rates_deg_s: str = Field("3,10,20", description="platform rates (deg/s), comma-separated")
    json_out: Path | None = Field(Path(TIMING_JSON), description="the ledger (finished runs are skipped)")

    @field_validator("rates_deg_s")
    @classmethod
    def _rates(cls, v: str) -> str:
        if not _floats(v) or any(not 0.0 < r <= 30.0 for r in _floats(v)):
            raise ValueError(f"rates must be in (0, 30] deg/s; got {v!r}")
        return v


def timing(p: TimingParams, log: Callable[[str], None]) -> str:
    """Eq. 15 against the simulated fall; the Eq. 15 swing against a fixed 1.5 s swing."""
    plan = [(f"{rate:g}:{c}:{v}", {"job": job}, lambda job=job: timing_run(job))
            for rate in _floats(p.rates_deg_s) for c in p.case_list() for v, rec in TIMINGS.items()
            for job in [tilt_job(CASES[c], p.max_tilt_deg, rate=rate, recovery=rec)]]
    return render_timing([_run_plan(p, p.json_out, "tipping-timing", TIMING_COMMAND, plan, log)])


class ConvergenceParams(BaseModel):
    steps_ms: str = Field("2,1", description="physics steps (ms) to check, comma-separated; each against its half")
    directions: str = Field("180,0,90,270,30,150", description="downhill directions (deg), stance 1-3-5")
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt (deg)")
    json_out: Path | None = Field(Path(CONVERGENCE_JSON), description="the ledger (finished runs are skipped)")

    @field_validator("steps_ms")
    @classmethod
    def _steps(cls, v: str) -> str:
        if not _floats(v) or any(not 0.5 <= s <= 2.0 for s in _floats(v)):
            raise ValueError(f"steps must be in [0.5, 2] ms (their halves >= the spec's 0.25 ms); got {v!r}")
        return v

    @field_validator("directions")
    @classmethod
    def _dirs(cls, v: str) -> str:
        if not _floats(v) or any(not 0.0 <= d < 360.0 for d in _floats(v)):
            raise ValueError(f"directions must be in [0, 360) deg; got {v!r}")
        return v


def convergence(p: ConvergenceParams, log: Callable[[str], None]) -> str:
    """The recovered answer at each step and at its half (a step both needs runs once)."""
    steps = list(dict.fromkeys(s for ms in _floats(p.steps_ms) for s in (ms, ms / 2)))
    plan = [(f"{ms:g}:{psi:g}", {"job": job}, lambda job=job: plain_run(job))
            for psi in _floats(p.directions) for ms in steps
            for job in [tilt_job(psi, p.max_tilt_deg, step_ms=ms)]]
    return render_convergence([_run_plan(p, p.json_out, "tipping-convergence", CONVERGENCE_COMMAND, plan, log)])


class RobustnessParams(_Check):
    json_out: Path | None = Field(Path(ROBUST_JSON), description="the ledger (finished runs are skipped)")


def robustness(p: RobustnessParams, log: Callable[[str], None]) -> str:
    """The job's robustness block of each case: the answer, then its seven re-runs."""
    plan = []
    for c in p.case_list():
        job = tilt_job(CASES[c], p.max_tilt_deg)
        plan.append((f"{c}:nominal", {"job": job, "run": "nominal"}, lambda job=job: nominal_run(job)))
        plan += [(f"{c}:{n}", {"job": job, "run": f"robust:{n}"}, lambda job=job, n=n: cliff_evidence("robust", n, job))
                 for n in ROBUSTNESS_CASES]
    return render_robustness([_run_plan(p, p.json_out, "tipping-robustness", ROBUST_COMMAND, plan, log)])

"""Issue 12's direction sweeps and cliff walk, re-run through ledgers (issue 28): the runs
behind docs/tipping.md's "Sweep" and "Cliff (Sec. 5.1)" sections, appended to
docs/tipping_sweep.json and docs/tipping_cliff.json as each finishes (a re-run skips the
runs there), and the sections rendered from them.

Sweep: the job ``{"kind": "tipping", "sweep": {"enabled": true, "directions": 12},
"evidence": {"controls": false, "robustness": false, "band": false}}`` at each final tilt,
with the QP (the default), without it (``"recovery": {"qp": false}``) and, at 48 deg, with
the 1 Hz posture feedback (``"recovery": {"posture_hz": 1.0}``). One ledger run is one
downhill direction of one such job: both tripods, with recovery; the runs without recovery
do not depend on the recovery's settings, so each (tilt, direction) has them once, shared
by the variants (the job would repeat them). Cliff: the job ``{"kind": "tipping",
"scenario": {"type": "cliff"}}``, one ledger run per simulation (the runs without and with
recovery, the three controls, the seven robustness re-runs)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger
from app.jobs.tipping.evidence import (ROBUSTNESS_CASES, control_setups, outcome, perturbed, robustness_cases,
                                       simulate)
from app.jobs.tipping.reproduce.reruns_docs import CLIFF_COMMAND, CLIFF_JSON, SWEEP_COMMAND, SWEEP_JSON, render_cliff, render_sweep
from app.jobs.tipping.run import _setup, sweep_run
from app.jobs.tipping.scenario import run_summary
from app.jobs.tipping.spec import TippingSpec

SCIENCE = ("app/jobs/tipping/scenario.py", "app/jobs/tipping/controller.py", "app/jobs/tipping/hexapod_sim.py",
           "app/jobs/tipping/stability", "app/jobs/tipping/evidence.py",
           "app/jobs/tipping/spec.py", "app/jobs/tipping/run.py", "app/robots/heavy_hexapod/__init__.py",
           "app/robots/pantograph.py")

SWEEP_JOB = {"kind": "tipping", "sweep": {"enabled": True, "directions": 12},
             "evidence": {"controls": False, "robustness": False, "band": False}}
# variant -> the job's recovery section (what differs from the default QP recovery)
VARIANTS = {"qp": {}, "no_qp": {"qp": False}, "posture_1hz": {"posture_hz": 1.0}}
CLIFF_JOB = {"kind": "tipping", "scenario": {"type": "cliff"}}


def _load() -> dict:
    return {"load_after": os.getloadavg()[0], "cores": os.cpu_count()}


def _names(text: str) -> list[str]:
    return [v.strip() for v in text.split(",") if v.strip()]


# -- the sweep ----------------------------------------------------------------------------------

def sweep_job(tilt_deg: float, variant: str, recovery: bool = True) -> dict:
    """The job spec of one sweep (JSON, as docs/tipping.md writes it); ``recovery`` False:
    the same job's runs without recovery."""
    rec = dict(VARIANTS[variant]) | ({} if recovery else {"enabled": False})
    return SWEEP_JOB | {"scenario": {"type": "tilt", "max_tilt_deg": float(tilt_deg)}} | ({"recovery": rec} if rec else {})


def sweep_direction(job: dict, psi: float) -> dict:
    """One downhill direction of the sweep job ``job``: a row per tripod (run.py's sweep rows)."""
    spec = TippingSpec.model_validate(job)
    rows = [sweep_run(spec, i, psi, tuple(st), spec.recovery.enabled) for i, st in enumerate(spec.sweep.stances)]
    return {"rows": rows} | _load()


TRACE_STEP_S = 1.0  # a traced run's body tilt and margin, sampled this often from the first landing


def trace_job(tilt_deg: float, psi: float, stance: str, variant: str) -> dict:
    """The job spec of one sweep run on its own (a tilt job in that direction and stance)."""
    rec = VARIANTS[variant]
    return ({"kind": "tipping", "scenario": {"type": "tilt", "downhill_deg": float(psi), "stance": [int(c) for c in stance],
                                              "max_tilt_deg": float(tilt_deg)}} | ({"recovery": dict(rec)} if rec else {}))


def trace_run(job: dict) -> dict:
    """One sweep run traced: its adjustments, when it tipped, and the body's tilt off the
    platform and the margin every ``TRACE_STEP_S`` from the first landing to the end."""
    spec = TippingSpec.model_validate(job)
    r = simulate(_setup(spec, True))
    tr, adj = r["trace"], r["adjustments"]
    keys = ("detect_time_s", "leg", "land_time_s", "margin_before_landing_deg", "margin_after_landing_deg")
    out = {"tipped": bool(r["tipped"]), "tipped_at_s": r["tipped_at_s"],
           "adjustments": [{k: a.get(k) for k in keys} for a in adj], "samples": []}
    land = next((a["land_time_s"] for a in adj if a.get("land_time_s") is not None), None)
    t = tr["time_s"]
    for k in range(int((t[-1] - land) / TRACE_STEP_S) + 1 if land is not None else 0):
        i = min(int(np.searchsorted(t, land + k * TRACE_STEP_S)), len(t) - 1)
        out["samples"].append({"time_s": float(t[i]), "body_off_platform_deg": float(tr["tilt_rel_deg"][i]),
                               "margin_deg": float(tr["fasm_deg"][i])})
    return out | _load()


class SweepParams(BaseModel):
    tilts_deg: str = Field("40,48", description="final platform tilts (deg), comma-separated, in the order run")
    variants: str = Field("qp,no_qp", description="recovery variants at every tilt (qp, no_qp, posture_1hz)")
    extra: str = Field("48:posture_1hz", description="one-off variants, tilt:variant, comma-separated, run last")
    traces: str = Field("40:90:246,48:60:246", description="single runs traced with the QP and without it, "
                                                 "tilt:downhill:stance, comma-separated, run after the sweeps")
    json_out: Path | None = Field(Path(SWEEP_JSON), description="the ledger: each finished direction is appended, "
                                                                "a re-run skips those already there")


def _sweep_plan(p: SweepParams) -> list[tuple[str, dict, Callable[[], dict]]]:
    """(run name, spec, work): per tilt, per direction, the runs without recovery and each
    variant's; then the one-off variants."""
    pairs = [(float(t), v) for t in _names(p.tilts_deg) for v in _names(p.variants)]
    extra = [(float(x.split(":")[0]), x.split(":")[1]) for x in _names(p.extra)]
    for _, v in pairs + extra:
        if v not in VARIANTS:
            raise ValueError(f"unknown sweep variant {v!r} (one of {', '.join(VARIANTS)})")
    n = SWEEP_JOB["sweep"]["directions"]
    out = []

    def add(tilt: float, variant: str | None, psi: float) -> None:
        job = sweep_job(tilt, variant or "qp", recovery=variant is not None)
        name = f"{tilt:g}:{variant or 'no_recovery'}:{psi:g}"
        out.append((name, {"job": job, "downhill_deg": psi}, lambda: sweep_direction(job, psi)))

    for tilt in dict.fromkeys(t for t, _ in pairs):
        for k in range(n):
            psi = 360.0 * k / n
            add(tilt, None, psi)
            for t, v in pairs:
                if t == tilt:
                    add(tilt, v, psi)
    for tilt, v in extra:
        for k in range(n):
            add(tilt, v, 360.0 * k / n)
    for x in _names(p.traces):
        tilt, psi, stance = x.split(":")
        for v in ("qp", "no_qp"):
            job = trace_job(float(tilt), float(psi), stance, v)
            out.append((f"trace:{float(tilt):g}:{v}:{float(psi):g}:{stance}", {"job": job}, lambda job=job: trace_run(job)))
    return out


def sweep(p: SweepParams, log: Callable[[str], None]) -> str:
    plan = _sweep_plan(p)
    led = Ledger(p.json_out, "tipping-sweep", SWEEP_COMMAND, p.model_dump(mode="json"), SCIENCE, planned=len(plan))
    for name, spec, work in plan:
        led.run(name, spec, 0, work, log)
    return render_sweep([led.data])


# -- the cliff ----------------------------------------------------------------------------------

FLAT_BEFORE_S = 1.0  # the flat-ground margin window ends this long before the margin first falls under 20 deg


def cliff_run(recovery: bool) -> dict:
    """The cliff walk without or with recovery: what a user reads, plus the margin's range
    on flat ground (from the first step to ``FLAT_BEFORE_S`` before the margin first falls under the threshold)."""
    spec = TippingSpec.model_validate(CLIFF_JOB)
    r = simulate(_setup(spec, recovery))
    out = run_summary(r, spec.detector.threshold_deg) | outcome(r)
    tr = r["trace"]
    end = (out["first_below_threshold_s"] or float(tr["time_s"][-1])) - FLAT_BEFORE_S
    flat = (tr["time_s"] >= spec.scenario.stand_s) & (tr["time_s"] <= end)
    out["flat_margin_deg"] = [float(tr["fasm_deg"][flat].min()), float(tr["fasm_deg"][flat].max())]
    out["flat_window_s"] = [spec.scenario.stand_s, float(end)]
    return out | _load()


def cliff_evidence(what: str, name: str, job: dict = CLIFF_JOB) -> dict:
    """One control (``what`` = "control") or robustness re-run of the cliff's recovery (or
    of ``job``'s: app/jobs/tipping/reproduce/checks.py runs the tilt cases' robustness blocks so)."""
    spec = TippingSpec.model_validate(job)
    answer = _setup(spec, True)
    if what == "control":
        s = next(s for n, _, s in control_setups(answer) if n == name)
    else:
        s = perturbed(answer, next(c for c in robustness_cases(answer) if c.name == name))
    return outcome(simulate(s)) | _load()


class CliffParams(BaseModel):
    json_out: Path | None = Field(Path(CLIFF_JSON), description="the ledger: each finished simulation is appended, "
                                                                "a re-run skips those already there")


def _cliff_plan() -> list[tuple[str, dict, Callable[[], dict]]]:
    out = [(n, {"job": CLIFF_JOB, "run": n}, lambda rec=rec: cliff_run(rec))
           for n, rec in (("no_recovery", False), ("recovery", True))]
    out += [(f"control:{n}", {"job": CLIFF_JOB, "run": f"control:{n}"}, lambda n=n: cliff_evidence("control", n))
            for n in ("no_qp", "position_stance", "fixed_swing")]
    out += [(f"robust:{n}", {"job": CLIFF_JOB, "run": f"robust:{n}"}, lambda n=n: cliff_evidence("robust", n))
            for n in ROBUSTNESS_CASES]
    return out


def cliff(p: CliffParams, log: Callable[[str], None]) -> str:
    plan = _cliff_plan()
    led = Ledger(p.json_out, "tipping-cliff", CLIFF_COMMAND, p.model_dump(mode="json"), SCIENCE, planned=len(plan))
    for name, spec, work in plan:
        led.run(name, spec, 0, work, log)
    return render_cliff([led.data])

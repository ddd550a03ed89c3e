"""The paper's six tilting-platform cases (Sec. 5.2, Fig. 6): climbing (y ccw), descending
(y cw) and the steep lateral slope, with legs 1-3-5 and with legs 2-4-6 in stance, each run
without and with recovery. ``gaitmend reproduce tipping`` prints the table in
docs/tipping.md."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable

import numpy as np
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.base import BenchEntry, Experiment
from app.jobs.evidence import controls_of
from app.robots.heavy_hexapod import HEAVY
from app.jobs.tipping.evidence import CONVERGENCE_TOL, EvidencePlan, Setup, convergence_row, outcome, run_evidence, simulate
from app.jobs.tipping.scenario import ControllerConfig, TiltScenario, first_catch, paper_direction, run_summary

PAPER_CASES = (  # (axis, direction, stance, the paper's adjustment leg)
    ("y", "ccw", (1, 3, 5), 6), ("y", "cw", (1, 3, 5), 4), ("x", "ccw", (1, 3, 5), 2),
    ("y", "ccw", (2, 4, 6), 3), ("y", "cw", (2, 4, 6), 1), ("x", "cw", (2, 4, 6), 5),
)


def paper_cases(duration_s: float = 20.0, rate_deg_s: float = 10.0, max_tilt_deg: float = 40.0, friction: float = 1.5,
                band_tol_deg: float = 1.0, robustness: bool = False, log: Callable[[str], None] = lambda m: None) -> list[dict]:
    """Each case at the job's defaults: the recovery run, its controls (no recovery, no QP,
    position-servoed stance, fixed swing time), the survivable tilt band with and without
    recovery, and (``robustness``) the perturbed re-runs."""
    rows = []
    plan = EvidencePlan(robustness=robustness, band_tol_deg=band_tol_deg)
    for axis, direction, stance, paper_leg in PAPER_CASES:
        sc = TiltScenario(downhill_deg=paper_direction(axis, direction), stance=stance, rate_deg_s=rate_deg_s,
                          max_tilt_deg=max_tilt_deg)
        setup = Setup(sc, ControllerConfig(), duration_s, friction=friction)
        r = simulate(setup)
        rec = run_summary(r, ControllerConfig().threshold_deg)
        base = outcome(simulate(setup.with_(cfg=ControllerConfig(recovery=False))))
        ev = run_evidence(setup, outcome(r), base, plan)
        first = first_catch(r["adjustments"]) or {}
        rows.append({"case": f"{axis} {direction}, stance {''.join(map(str, stance))}", "paper_leg": paper_leg,
                     "tipped_without": base["tipped"], "tipped_without_at_s": base["tipped_at_s"],
                     "tipped_with": rec["tipped"], "detection_time_s": rec.get("detection_time_s"),
                     "edge": rec.get("tipping_edge"), "leg": rec.get("adjustment_leg"),
                     "foothold_body_m": rec.get("foothold_body_m"), "time_to_tip_s": rec.get("time_to_tip_s"),
                     "swing_s": first.get("swing_s"), "adjustment_time_s": rec.get("adjustment_time_s"),
                     "margin_at_detection_deg": rec.get("margin_at_detection_deg"),
                     "margin_before_deg": rec.get("margin_before_landing_deg"),
                     "margin_after_deg": rec.get("margin_after_landing_deg"),
                     "final_margin_deg": rec["final_margin_deg"], "static_tip_deg": rec.get("static_tip_deg"),
                     "max_tilt_deg": rec.get("max_tilt_deg"), "control_ms_mean": r["control_ms_mean"], **ev})
        log(f"{rows[-1]['case']}: done")
    return rows


def _n(v, fmt):
    return "-" if v is None else fmt.format(v)


def markdown(rows: list[dict]) -> str:
    head = ("| case | detected (s) | edge | leg (paper) | foothold body (m) | t_s Eq.15 (s) | swing (s) "
            "| margin at detection / before landing / after (deg) | no recovery | recovery |\n|---|---|---|---|---|---|---|---|---|---|\n")
    out = []
    for r in rows:
        fh = "(" + ", ".join(f"{v:.2f}" for v in r["foothold_body_m"]) + ")" if r["foothold_body_m"] else "-"
        without = f"tips at {r['tipped_without_at_s']:.1f} s" if r["tipped_without"] else "stays up"
        out.append(f"| {r['case']} | {_n(r['detection_time_s'], '{:.2f}')} | {r['edge'] or '-'} | "
                   f"{r['leg'] or '-'} ({r['paper_leg']}) | {fh} "
                   f"| {_n(r['time_to_tip_s'], '{:.2f}')} | {_n(r['swing_s'], '{:.2f}')} | "
                   f"{_n(r['margin_at_detection_deg'], '{:.1f}')} / "
                   f"{_n(r['margin_before_deg'], '{:.1f}')} / {_n(r['margin_after_deg'], '{:.1f}')} "
                   f"| {without} | {'tips' if r['tipped_with'] else 'stays up'} |")
    md = head + "\n".join(out)
    md += ("\n\n| case | upright with recovery / no QP / position stance / fixed 1.5 s swing "
           "| margin after landing (deg): same order | survivable final tilt with / without recovery (deg) |"
           "\n|---|---|---|---|\n")
    for r in rows:
        ctl = {c.name: c.metrics for c in controls_of(r)}
        order = ["no_qp", "position_stance", "fixed_swing"]
        up = " / ".join(["yes" if not r["tipped_with"] else "no"]
                        + ["yes" if not ctl[k]["tipped"] else "no" for k in order if k in ctl])
        ma = " / ".join([_n(r["margin_after_deg"], "{:.1f}")]
                        + [_n(ctl[k]["margin_after_landing_deg"], "{:.1f}") for k in order if k in ctl])
        b = r.get("band", {})
        band = " / ".join(_n(b.get(k, {}).get("max_upright_deg"), "{:.1f}") for k in ("with_recovery", "without_recovery"))
        md += f"| {r['case']} | {up} | {ma} | {band} |\n"
    return md


class CasesParams(BaseModel):
    duration_s: float = Field(20.0, gt=1.0, le=120.0, description="simulated seconds per run (at least)")
    rate_deg_s: float = Field(10.0, gt=0.0, le=30.0, description="platform rate")
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt")
    friction: float = Field(1.5, gt=0.1, le=3.0, description="foot-ground friction")
    band_tolerance_deg: float = Field(1.0, ge=0.1, le=10.0, description="bisection tolerance of the survivable tilt")
    robustness: bool = Field(False, description="also re-run each case under the perturbations")
    out: Path | None = Field(None, description="also write the markdown table here")
    json_out: Path | None = Field(None, description="also write the rows as JSON here")


def cases(p: CasesParams, log: Callable[[str], None]) -> str:
    rows = paper_cases(p.duration_s, p.rate_deg_s, p.max_tilt_deg, p.friction, p.band_tolerance_deg, p.robustness, log)
    md = markdown(rows)
    if p.out:
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(md + "\n")
    if p.json_out:
        p.json_out.write_text(json.dumps(rows, indent=1))
    return md


# -- the checks behind issue 12's findings ------------------------------------------------------

CHECK_DIRECTIONS = ((180.0, "climbing (y ccw)"), (0.0, "descending (y cw)"), (90.0, "lateral (x ccw)"))


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def _row_md(cells) -> str:
    return "| " + " | ".join(cells) + " |"


class ConvergenceParams(BaseModel):
    steps_ms: str = Field("2,1", description="physics steps (ms) to check, comma-separated; each against its half")
    directions: str = Field("180,0,90,270,30,150", description="downhill directions (deg), stance 1-3-5")
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt")


def convergence(p: ConvergenceParams, log: Callable[[str], None]) -> str:
    """The convergence rule on recovered answers: tipped or not, margin after landing and
    detection time at a step and at its half."""
    md = ["| step (ms) vs half | downhill (deg) | tipped | margin after landing (deg) | detection (s) "
          "| Eq. 15 t_s (s) | within tolerance |", "|---|---|---|---|---|---|---|"]
    for ms in _floats(p.steps_ms):
        for psi in _floats(p.directions):
            s = Setup(TiltScenario(downhill_deg=psi, max_tilt_deg=p.max_tilt_deg), ControllerConfig())
            a = outcome(simulate(s.with_(geom=dataclasses.replace(HEAVY, timestep=ms / 1e3))))
            b = outcome(simulate(s.with_(geom=dataclasses.replace(HEAVY, timestep=ms / 2e3))))
            row = convergence_row(a, b)
            md.append(_row_md([f"{ms:g} vs {ms / 2:g}", f"{psi:g}", f"{a['tipped']} / {b['tipped']}",
                               f"{_n(a['margin_after_landing_deg'], '{:.2f}')} / {_n(b['margin_after_landing_deg'], '{:.2f}')}",
                               f"{_n(a['detection_time_s'], '{:.2f}')} / {_n(b['detection_time_s'], '{:.2f}')}",
                               f"{_n(a['time_to_tip_s'], '{:.2f}')} / {_n(b['time_to_tip_s'], '{:.2f}')}",
                               "yes" if row["ok"] else "no"]))
            log(md[-1])
    return "\n".join(md) + f"\n\ntolerance: {CONVERGENCE_TOL}, tipped must agree"


def qp_force_error(r: dict) -> float | None:
    """Largest |mean measured - mean QP force| over the stance feet from 1 s after the
    caught leg lands to the end, in % of the robot's weight (None: no landing, or tipped)."""
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


class FrictionParams(BaseModel):
    frictions: str = Field("1.5,1.0,0.9", description="foot-ground friction coefficients, comma-separated")
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt")


def friction(p: FrictionParams, log: Callable[[str], None]) -> str:
    """Does the QP force distribution matter on low friction? Recovery with force-controlled
    stance legs (the QP's forces), with position-servoed ones, and without the QP."""
    modes = (("QP, force-controlled stance", {}), ("QP as feed-forward, position servos", {"stance_control": "position"}),
             ("no QP", {"qp": False}))
    md = ["| friction | case | stance control | tipped | foot slip (m) | friction demand | margin after landing (deg) "
          "| measured - QP force, worst stance foot (% of weight) |", "|---|---|---|---|---|---|---|---|"]
    for mu in _floats(p.frictions):
        for psi, name in CHECK_DIRECTIONS:
            for label, kw in modes:
                s = Setup(TiltScenario(downhill_deg=psi, max_tilt_deg=p.max_tilt_deg), ControllerConfig(**kw), friction=mu)
                r = simulate(s)
                o = outcome(r)
                md.append(_row_md([f"{mu:g}", name, label, "yes" if o["tipped"] else "no", f"{o['max_slip_m']:.3f}",
                                   _n(o["friction_demand"], "{:.2f}"), _n(o["margin_after_landing_deg"], "{:.1f}"),
                                   _n(qp_force_error(r), "{:.1f}")]))
                log(md[-1])
    return "\n".join(md)


class TimingParams(BaseModel):
    rates_deg_s: str = Field("3,10,20", description="platform rates (deg/s), comma-separated")
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0, description="fixed final platform tilt")


def timing(p: TimingParams, log: Callable[[str], None]) -> str:
    """Eq. 15 against the simulated fall, and the swing it sets against a fixed 1.5 s swing."""
    md = ["| rate (deg/s) | case | Eq. 15 t_s (s) | t_s / kappa (s) | margin reached 0 after (s, no recovery) "
          "| swing Eq. 15 / fixed (s) | upright Eq. 15 / fixed | margin after landing Eq. 15 / fixed (deg) |",
          "|---|---|---|---|---|---|---|---|"]
    for rate in _floats(p.rates_deg_s):
        for psi, name in CHECK_DIRECTIONS:
            sc = TiltScenario(downhill_deg=psi, max_tilt_deg=p.max_tilt_deg, rate_deg_s=rate)
            cfg = ControllerConfig()
            eq, fixed = (outcome(simulate(Setup(sc, c))) for c in (cfg, dataclasses.replace(cfg, swing_timing="fixed")))
            tr = simulate(Setup(sc, ControllerConfig(recovery=False)))["trace"]
            fall = None
            if eq["detection_time_s"] is not None:
                after = (tr["time_s"] > eq["detection_time_s"]) & (tr["fasm_deg"] <= 0.0)
                fall = float(tr["time_s"][after.argmax()] - eq["detection_time_s"]) if after.any() else None
            ts = eq["time_to_tip_s"]
            md.append(_row_md([f"{rate:g}", name, _n(ts, "{:.2f}"), _n(None if ts is None else ts / cfg.kappa, "{:.2f}"),
                               _n(fall, "{:.2f}"), f"{_n(eq['swing_s'], '{:.2f}')} / {_n(fixed['swing_s'], '{:.2f}')}",
                               f"{'yes' if not eq['tipped'] else 'no'} / {'yes' if not fixed['tipped'] else 'no'}",
                               f"{_n(eq['margin_after_landing_deg'], '{:.1f}')} / "
                               f"{_n(fixed['margin_after_landing_deg'], '{:.1f}')}"]))
            log(md[-1])
    return "\n".join(md)


EXPERIMENTS = [Experiment("cases", "The paper's six tilting-platform cases (Sec. 5.2, Fig. 6), each without and "
                                   "with recovery, with the controls and the survivable tilt band", CasesParams, cases),
               Experiment("convergence", "Recovered answers at a physics step and at its half (the convergence rule)",
                          ConvergenceParams, convergence),
               Experiment("friction", "Low friction: QP with force-controlled stance vs position servos vs no QP",
                          FrictionParams, friction),
               Experiment("timing", "Eq. 15 time-to-tip against the simulated fall; Eq. 15 swing vs a fixed 1.5 s swing",
                          TimingParams, timing)]


def _bench(quick: bool, log: Callable[[str], None]) -> dict:
    from app.jobs.tipping.bench import bench_tipping

    return bench_tipping(steps=100 if quick else 500)


BENCH = [BenchEntry("tipping", "FASM + judgment + QP per control step", _bench)]

"""Evidence for a tipping answer (issue 12): the survivable tilt band by bisection on real
runs, the controls (recovery without the QP, with position-servoed stance legs, with a fixed
swing time instead of Eq. 15, and no recovery at all) on the same scenario, the answer
re-simulated under perturbations (timestep, friction, masses, payload), and the timestep
convergence check. Every number here comes from a full MuJoCo run of ``run_tilt``."""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from app.robots.heavy_hexapod import HEAVY, HeavyHexapodGeometry, scaled_masses
from app.stability.scenario import ControllerConfig, TiltScenario, first_catch, run_tilt


@dataclasses.dataclass(frozen=True)
class Setup:
    """Everything one tilting-platform simulation needs."""

    scen: TiltScenario
    cfg: ControllerConfig
    duration_s: float = 20.0
    geom: HeavyHexapodGeometry = HEAVY
    friction: float = 1.5

    def with_(self, **kw) -> Setup:
        return dataclasses.replace(self, **kw)


def simulate(setup: Setup, record_qpos: bool = False) -> dict:
    return run_tilt(setup.scen, setup.cfg, setup.duration_s, geom=setup.geom, friction=setup.friction,
                    record_qpos=record_qpos)


def outcome(r: dict) -> dict:
    """The answers a user reads off one run (numbers or None, JSON-ready)."""
    first = first_catch(r["adjustments"])
    m = r["trace"]["fasm_deg"]
    tr = r["trace"]
    last = tr["time_s"] > tr["time_s"][-1] - 1.0
    out = {"tipped": bool(r["tipped"]), "tipped_at_s": r["tipped_at_s"],
           "final_margin_deg": float(m[-1]) if not r["tipped"] else None,
           "max_slip_m": float(r["max_slip_m"]),
           # friction the feet need at the end (largest tangential / normal force over the
           # loaded feet, median over the last second): what the ground must offer to hold
           "friction_demand": float(np.median(tr["friction_ratio"][last])) if not r["tipped"] else None}
    det = r["adjustments"][0] if r["adjustments"] else None
    out["detection_time_s"] = det["detect_time_s"] if det else None
    for k in ("leg", "time_to_tip_s", "swing_s", "adjustment_time_s", "margin_after_landing_deg"):
        out[k] = first.get(k) if first else None
    return out


def target_met(metrics: dict, target_margin_deg: float) -> bool:
    """The recovery's target: the robot stays up to the end of the run and, if a leg was
    caught, the margin 0.5 s after its landing is at least ``target_margin_deg``."""
    if metrics["tipped"]:
        return False
    after = metrics.get("margin_after_landing_deg")
    return after is None or after >= target_margin_deg


def target_text(target_margin_deg: float) -> str:
    return f"stays upright to the end of the run; margin 0.5 s after the caught leg lands >= {target_margin_deg:g} deg"


# -- survivable tilt band ---------------------------------------------------------------------

def survivable_tilt(setup: Setup, lo: float = 10.0, hi: float = 60.0, tol: float = 1.0,
                    run: Callable[[Setup], dict] = simulate, between: Callable[[], None] | None = None) -> dict:
    """Largest final platform tilt the robot survives (stays upright) for this direction,
    stance and controller, by bisection on real runs: each probe turns the platform to that
    final tilt at the scenario's rate and holds it. Assumes one switch from upright to tipped
    along the tilt (the probes are returned so a reader can check it). ``between`` runs
    before every probe (progress, cancel)."""
    probes: list[dict] = []

    def tips(angle: float) -> bool:
        if between is not None:
            between()
        r = run(setup.with_(scen=dataclasses.replace(setup.scen, max_tilt_deg=angle)))
        probes.append({"final_tilt_deg": round(angle, 4), "tipped": bool(r["tipped"])})
        return bool(r["tipped"])

    if tips(lo):
        return {"max_upright_deg": None, "min_tipped_deg": lo, "probes": probes, "evaluations": len(probes),
                "note": f"tips already at {lo:g} deg"}
    if not tips(hi):
        return {"max_upright_deg": hi, "min_tipped_deg": None, "probes": probes, "evaluations": len(probes),
                "note": f"upright up to the {hi:g} deg limit"}
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if tips(mid):
            hi = mid
        else:
            lo = mid
    return {"max_upright_deg": lo, "min_tipped_deg": hi, "probes": probes, "evaluations": len(probes), "note": ""}


def band_runs(lo: float, hi: float, tol: float) -> int:
    """Simulations one ``survivable_tilt`` call makes when the answer lies inside (lo, hi)."""
    return 2 + max(0, math.ceil(math.log2((hi - lo) / tol)))


# -- controls ---------------------------------------------------------------------------------

CONTROLS = (
    ("no_recovery", "no recovery: the judgment runs, no leg is swung", {"recovery": False}),
    ("no_qp", "recovery without the QP force distribution (stiff position servos only)", {"qp": False}),
    ("position_stance", "recovery with the QP only as feed-forward beside stiff position servos (before issue 12)",
     {"stance_control": "position"}),
    ("fixed_swing", "recovery with a fixed 1.5 s swing instead of the Eq. 15 time-to-tip", {"swing_timing": "fixed"}),
)


def control_setups(setup: Setup) -> list[tuple[str, str, Setup]]:
    return [(name, label, setup.with_(cfg=dataclasses.replace(setup.cfg, **kw))) for name, label, kw in CONTROLS]


# -- robustness -------------------------------------------------------------------------------

def robustness_setups(setup: Setup) -> list[tuple[str, str, Setup]]:
    g, f = setup.geom, setup.friction
    return [
        ("dt_half", f"physics step {g.timestep / 2 * 1e3:g} ms", setup.with_(geom=dataclasses.replace(g, timestep=g.timestep / 2))),
        ("dt_quarter", f"physics step {g.timestep / 4 * 1e3:g} ms",
         setup.with_(geom=dataclasses.replace(g, timestep=g.timestep / 4))),
        ("friction_0.7", f"friction x0.7 ({0.7 * f:.2f})", setup.with_(friction=0.7 * f)),
        ("friction_1.3", f"friction x1.3 ({1.3 * f:.2f})", setup.with_(friction=1.3 * f)),
        ("mass_+10pct", "every link mass +10 %", setup.with_(geom=scaled_masses(g, 1.1))),
        ("mass_-10pct", "every link mass -10 %", setup.with_(geom=scaled_masses(g, 0.9))),
        ("payload", "500 kg payload on top of the body (CoG raised)",
         setup.with_(geom=dataclasses.replace(g, payload_kg=500.0))),
    ]


ROBUST_METRICS = ("margin_after_landing_deg", "detection_time_s", "time_to_tip_s", "final_margin_deg", "max_slip_m",
                  "friction_demand")


def spread(nominal: dict, cases: list[dict]) -> dict:
    out = {}
    for k in ROBUST_METRICS:
        vals = [c["metrics"][k] for c in cases if c["metrics"].get(k) is not None]
        if nominal.get(k) is None and not vals:
            continue
        allv = vals + ([nominal[k]] if nominal.get(k) is not None else [])
        out[k] = {"min": min(allv), "max": max(allv), "nominal": nominal.get(k)}
    return out


# -- numerical convergence --------------------------------------------------------------------

CONVERGENCE_TOL = {"margin_after_landing_deg": 2.0, "detection_time_s": 0.1}


def convergence_row(coarse: dict, fine: dict, tol: dict = CONVERGENCE_TOL) -> dict:
    """Do the final answers move less than ``tol`` when the step is halved? Tipped or not
    must agree; the numbers within their tolerance (both None also agrees)."""
    diffs, ok = {}, coarse["tipped"] == fine["tipped"]
    for k, t in tol.items():
        a, b = coarse.get(k), fine.get(k)
        if a is None or b is None:
            ok &= a is None and b is None
            diffs[k] = None
            continue
        diffs[k] = abs(a - b)
        ok &= diffs[k] <= t
    return {"tipped": [coarse["tipped"], fine["tipped"]], "diff": diffs, "ok": bool(ok)}

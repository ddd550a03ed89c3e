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
from app.jobs.tipping.scenario import CliffScenario, ControllerConfig, TiltScenario, first_catch, run_cliff, run_tilt


@dataclasses.dataclass(frozen=True)
class Setup:
    """Everything one tilting-platform simulation needs."""

    scen: TiltScenario | CliffScenario
    cfg: ControllerConfig
    duration_s: float = 20.0
    geom: HeavyHexapodGeometry = HEAVY
    friction: float = 1.5

    def with_(self, **kw) -> Setup:
        return dataclasses.replace(self, **kw)


def simulate(setup: Setup, record_qpos: bool = False) -> dict:
    if isinstance(setup.scen, CliffScenario):
        return run_cliff(setup.scen, setup.cfg, setup.duration_s, geom=setup.geom, friction=setup.friction,
                         record_qpos=record_qpos)
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

ROBUSTNESS_CASES = ("dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_+10pct", "mass_-10pct", "payload")


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


# -- all of it, for a job ---------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class EvidencePlan:
    controls: bool = True
    robustness: bool = True
    band: bool = True  # tilting platform only
    band_lo_deg: float = 10.0
    band_hi_deg: float = 60.0
    band_tol_deg: float = 1.0
    target_margin_deg: float = 0.0

    def runs(self, tilt: bool, n_robust: int = len(ROBUSTNESS_CASES)) -> int:
        """Upper bound on the simulations ``run_evidence`` makes."""
        n = len(CONTROLS) - 1 if self.controls else 0  # no_recovery is the job's own baseline run
        n += n_robust if self.robustness else 0
        if self.band and tilt:
            n += 2 * band_runs(self.band_lo_deg, self.band_hi_deg, self.band_tol_deg)
        return n


def run_evidence(setup: Setup, nominal: dict, baseline: dict, plan: EvidencePlan,
                 before: Callable[[str], None] = lambda key: None, cache: dict | None = None,
                 on_done: Callable[[str, dict], None] = lambda key, value: None) -> dict:
    """Controls, robustness and the survivable tilt band for the recovery answer ``setup``
    (whose outcome is ``nominal``; ``baseline`` is the same scenario without recovery), in
    the shared result format. ``before(key)`` runs before every simulation (progress and
    cancel); finished units are looked up in / reported to ``cache`` / ``on_done`` by key so
    a resumed job does not repeat them."""
    cache = {} if cache is None else cache

    def unit(key: str, make: Callable[[], dict]) -> dict:
        if key not in cache:
            before(key)
            cache[key] = make()
            on_done(key, cache[key])
        return cache[key]

    tgt = plan.target_margin_deg
    out: dict = {}
    if plan.controls:
        rows = [{"name": "no_recovery", "label": CONTROLS[0][1], "evaluations": 1, "metrics": baseline,
                 "target_met": target_met(baseline, tgt), "note": "the job's baseline run"}]
        for name, label, s in control_setups(setup)[1:]:
            m = unit(f"control:{name}", lambda s=s: outcome(simulate(s)))
            rows.append({"name": name, "label": label, "evaluations": 1, "metrics": m, "target_met": target_met(m, tgt),
                         "note": "same scenario, same physics; one simulation like the method"})
        out["controls"] = rows
    if plan.robustness:
        cases = []
        for name, label, s in robustness_setups(setup):
            m = unit(f"robust:{name}", lambda s=s: outcome(simulate(s)))
            cases.append({"name": name, "label": label, "metrics": m, "target_met": target_met(m, tgt)})
        out["robustness"] = {"target": target_text(tgt), "cases": cases,
                             "met": sum(bool(c["target_met"]) for c in cases), "total": len(cases),
                             "spread": spread(nominal, cases)}
    if plan.band and isinstance(setup.scen, TiltScenario):
        band = {}
        for name, cfg in (("with_recovery", setup.cfg), ("without_recovery", dataclasses.replace(setup.cfg, recovery=False))):
            def run_probe(s: Setup, name=name) -> dict:
                key = f"band:{name}:{s.scen.max_tilt_deg:.4f}"
                return unit(key, lambda: {"tipped": bool(simulate(s)["tipped"])})
            band[name] = survivable_tilt(setup.with_(cfg=cfg), plan.band_lo_deg, plan.band_hi_deg, plan.band_tol_deg,
                                         run=run_probe)
        a, b = band["with_recovery"]["max_upright_deg"], band["without_recovery"]["max_upright_deg"]
        band["gain_deg"] = None if a is None or b is None else a - b
        band["tolerance_deg"] = plan.band_tol_deg
        out["band"] = band
    return out

"""Evidence for a tipping answer (issue 12): the survivable tilt band by bisection on real
runs, the controls (recovery without the QP, with position-servoed stance legs, with a fixed
swing time instead of Eq. 15, and no recovery at all) on the same scenario, the answer
re-simulated under perturbations (timestep, friction, masses, payload), and the timestep
convergence check. Every number here comes from a full MuJoCo run of ``run_tilt``."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from typing import Any, Callable

import numpy as np

from app.jobs import evidence as protocol
from app.jobs.evidence import Case, CaseResult, ControlRow, Robustness, Target
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


# -- the target -------------------------------------------------------------------------------

def _upright_with_margin(margin_deg: float, metrics: Mapping[str, Any]) -> bool:
    if metrics["tipped"]:
        return False
    after = metrics.get("margin_after_landing_deg")
    return after is None or after >= margin_deg


def recovery_target(margin_deg: float = 0.0) -> Target:
    """The recovery's target, the one the job's evidence, its pages and the experiments all
    judge by: the robot stays up to the end of the run and, if a leg was caught, the margin
    0.5 s after its landing is at least ``margin_deg`` (the spec's
    ``evidence.target_margin_deg``). It reads an ``outcome`` or a run's summary alike."""
    return Target(f"stays upright to the end of the run; margin 0.5 s after the caught leg lands >= {margin_deg:g} deg",
                  functools.partial(_upright_with_margin, margin_deg))


def target_of(summary: Mapping[str, Any]) -> Target:
    """The target a stored summary was judged by."""
    return recovery_target(summary.get("target_margin_deg", 0.0))


# -- finished simulations, by key -------------------------------------------------------------

class Units:
    """The finished simulations of one phase by key, so that a resumed job does not repeat
    them; ``on_done(key, value)`` runs after each new one (checkpoint, progress, cancel)."""

    def __init__(self, done: dict | None = None, on_done: Callable[[str, dict], None] | None = None):
        self.done = {} if done is None else done
        self.on_done = on_done

    def get(self, key: str, make: Callable[[], dict]) -> dict:
        if key not in self.done:
            self.done[key] = make()
            if self.on_done is not None:
                self.on_done(key, self.done[key])
        return self.done[key]



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


def _band_probe(units: Units, name: str, s: Setup) -> dict:
    return units.get(f"band:{name}:{s.scen.max_tilt_deg:.4f}", lambda: {"tipped": bool(simulate(s)["tipped"])})


def band(setup: Setup, plan: EvidencePlan, units: Units | None = None) -> dict:
    """The survivable tilt with and without recovery, and what recovery gains."""
    units = Units() if units is None else units
    out: dict = {}
    for name, cfg in (("with_recovery", setup.cfg), ("without_recovery", dataclasses.replace(setup.cfg, recovery=False))):
        out[name] = survivable_tilt(setup.with_(cfg=cfg), plan.band_lo_deg, plan.band_hi_deg, plan.band_tol_deg,
                                    run=functools.partial(_band_probe, units, name))
    a, b = out["with_recovery"]["max_upright_deg"], out["without_recovery"]["max_upright_deg"]
    out["gain_deg"] = None if a is None or b is None else a - b
    out["tolerance_deg"] = plan.band_tol_deg
    return out


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


def control_rows(setup: Setup, baseline: dict, target: Target, units: Units | None = None) -> list[dict]:
    """``summary["controls"]``: the job's own run without recovery (``baseline``), then the
    method with each part switched off, on the same scenario."""
    units = Units() if units is None else units
    rows = [ControlRow("no_recovery", CONTROLS[0][1], baseline, target.met(baseline), 1, "the job's baseline run")]
    for name, label, s in control_setups(setup)[1:]:
        m = units.get(f"control:{name}", lambda s=s: outcome(simulate(s)))
        rows.append(ControlRow(name, label, m, target.met(m), 1,
                               "same scenario, same physics; one simulation like the method"))
    return [r.to_json() for r in rows]


# -- robustness -------------------------------------------------------------------------------

ROBUSTNESS_CASES = ("dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_+10pct", "mass_-10pct", "payload")
PAYLOAD_KG = 500.0  # on top of the body: raises the CoG of a 5 t robot


def _label(c: Case, setup: Setup) -> str:
    """The kind's words for a standard case: the step or friction it becomes, the payload."""
    if c.timestep_scale != 1.0:
        return f"physics step {setup.geom.timestep * c.timestep_scale * 1e3:g} ms"
    if c.friction_scale != 1.0:
        return f"friction x{c.friction_scale:g} ({c.friction_scale * setup.friction:.2f})"
    if c.mass_scale != 1.0:
        return f"every link mass {round(100 * (c.mass_scale - 1)):+d} %"
    if c.name == "payload":
        return f"{PAYLOAD_KG:g} kg payload on top of the body (CoG raised)"
    raise ValueError(f"tipping does not run the robustness case {c.name!r}")


def robustness_cases(setup: Setup) -> list[Case]:
    return [protocol.case(name, _label(protocol.case(name), setup)) for name in ROBUSTNESS_CASES]


def perturbed(setup: Setup, c: Case) -> Setup:
    """``setup`` in the world of case ``c``."""
    g = setup.geom
    if c.timestep_scale != 1.0:
        g = dataclasses.replace(g, timestep=g.timestep * c.timestep_scale)
    if c.mass_scale != 1.0:
        g = scaled_masses(g, c.mass_scale)
    if c.name == "payload":
        g = dataclasses.replace(g, payload_kg=PAYLOAD_KG)
    return setup.with_(geom=g, friction=c.friction_scale * setup.friction)


ROBUST_METRICS = ("margin_after_landing_deg", "detection_time_s", "time_to_tip_s", "final_margin_deg", "max_slip_m",
                  "friction_demand")


def robustness(setup: Setup, nominal: dict, target: Target, units: Units | None = None) -> Robustness:
    """The recovery answer ``setup`` (whose outcome is ``nominal``) re-simulated under each
    case; the spread keeps each metric as the runs gave it."""
    units = Units() if units is None else units
    cases = []
    for c in robustness_cases(setup):
        m = units.get(f"robust:{c.name}", lambda c=c: outcome(simulate(perturbed(setup, c))))
        cases.append(CaseResult(c.name, c.label, m, target.met(m)).to_json())
    return Robustness.build(target.text, nominal, cases, keys=ROBUST_METRICS, as_float=False)


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

    @property
    def target(self) -> Target:
        return recovery_target(self.target_margin_deg)

    def sizes(self, tilt: bool) -> dict[str, int]:
        """Upper bound on the simulations of each evidence phase, in the order they run."""
        out = {}
        if self.controls:
            out["controls"] = len(CONTROLS) - 1  # no_recovery is the job's own baseline run
        if self.robustness:
            out["robustness"] = len(ROBUSTNESS_CASES)
        if self.band and tilt:
            out["band"] = 2 * band_runs(self.band_lo_deg, self.band_hi_deg, self.band_tol_deg)
        return out


def run_evidence(setup: Setup, nominal: dict, baseline: dict, plan: EvidencePlan) -> dict:
    """Controls, robustness and the survivable tilt band for the recovery answer ``setup``
    (whose outcome is ``nominal``; ``baseline`` is the same scenario without recovery), in
    the shared result format, all at once (a job runs them as phases: app.jobs.tipping.run)."""
    out: dict = {}
    if plan.controls:
        out["controls"] = control_rows(setup, baseline, plan.target)
    if plan.robustness:
        out["robustness"] = robustness(setup, nominal, plan.target).to_json()
    if plan.band and isinstance(setup.scen, TiltScenario):
        out["band"] = band(setup, plan)
    return out

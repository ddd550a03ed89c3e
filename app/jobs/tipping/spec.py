"""The ``tipping`` spec (paper 002): the scenario (tilting platform or cliff walk),
detector, recovery controller, simulation and the optional direction sweep."""

from __future__ import annotations

import dataclasses
from typing import Annotated, ClassVar, Literal, Union

from pydantic import Field, field_validator, model_validator

from app.jobs.base import SpecBase, StrictModel
from app.robots.heavy_hexapod import HEAVY, TRIPODS
from app.jobs.tipping.evidence import EvidencePlan
from app.jobs.tipping.scenario import CliffScenario, ControllerConfig, TiltScenario, paper_direction

Tripod = Annotated[list[Annotated[int, Field(ge=1, le=6)]], Field(max_length=6)]


def _check_tripod(v: list[int]) -> list[int]:
    if tuple(sorted(v)) not in TRIPODS:
        raise ValueError(f"must be a tripod, [1, 3, 5] or [2, 4, 6]; got {v}")
    return sorted(v)


class TiltIn(StrictModel):
    """Tilting platform (Sec. 5.2). Direction either as the paper names it (``axis`` +
    ``direction``; ccw as seen from the axis's negative end: y ccw = climbing, the robot tips
    backward; x ccw = it tips to its left) or as ``downhill_deg`` (0 = the robot's front
    goes down, 90 = its left side), not both."""

    type: Literal["tilt"] = "tilt"
    axis: Literal["x", "y"] | None = None
    direction: Literal["ccw", "cw"] | None = None
    downhill_deg: float | None = Field(None, ge=0.0, lt=360.0)
    # The paper gives no rate; its Eq. 15 times (0.74-2.31 s from a 20 deg margin, kappa < 1)
    # imply margins falling 7-22 deg/s, and on the platform the margin falls at about the
    # platform's rate (docs/tipping.md).
    rate_deg_s: float = Field(10.0, gt=0.0, le=30.0)
    stance: Tripod = Field(default_factory=lambda: [1, 3, 5])
    settle_s: float = Field(3.0, ge=0.5, le=20.0)
    # The fixed final tilt the platform turns to and holds; it never depends on the robot.
    max_tilt_deg: float = Field(40.0, gt=0.0, le=60.0)
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
                            settle_s=self.settle_s, max_tilt_deg=self.max_tilt_deg, hold_s=self.hold_s)


class CliffIn(StrictModel):
    """Tripod walking from flat ground onto a unilateral cliff (Sec. 5.1)."""

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


class TippingDetector(StrictModel):
    threshold_deg: float = Field(20.0, gt=0.0, le=60.0)  # xi_f, Sec. 3
    kappa: float = Field(0.8, gt=0.0, lt=1.0)  # Eq. 15


class TippingRecovery(StrictModel):
    enabled: bool = True
    safety_margin: float = Field(0.9, gt=0.0, lt=1.0)  # rho, Eq. 11-13
    cone_lambda: float = Field(0.9, gt=0.0, lt=1.0)  # lambda, Eq. 21
    qp: bool = True
    mu_qp: float = Field(1.2, gt=0.0, le=2.0)
    # Swing time: "eq15" = the Eq. 15 time-to-tip clipped to [swing_min_s, swing_max_s];
    # "fixed" = fixed_swing_s whatever Eq. 15 says.
    swing_timing: Literal["eq15", "fixed"] = "eq15"
    swing_min_s: float = Field(0.4, gt=0.0, le=5.0)
    swing_max_s: float = Field(4.0, gt=0.0, le=10.0)
    fixed_swing_s: float = Field(1.5, gt=0.0, le=10.0)
    clearance_m: float = Field(0.25, ge=0.0, le=0.8)
    max_adjustments: int = Field(2, ge=1, le=3)
    # Stance legs once the QP runs: "force" = compliant about where they stand, pushing the
    # QP's forces (tau = -J^T f); "position" = stiff servos, the QP as feed-forward only.
    stance_control: Literal["force", "position"] = "force"
    compliance: float = Field(0.03, gt=0.0, le=1.0)  # servo stiffness factor in force mode
    # Posture feedback in the QP's target wrench (Eq. 16's a_b): bandwidth in Hz, 0 = off
    # (the default; the paper does not say what sets a_b).
    posture_hz: float = Field(0.0, ge=0.0, le=5.0)

    @model_validator(mode="after")
    def _swing_order(self):
        if self.swing_min_s > self.swing_max_s:
            raise ValueError(f"swing_min_s {self.swing_min_s} exceeds swing_max_s {self.swing_max_s}")
        return self


class TippingSim(StrictModel):
    # None: 20 s tilt, 32 s cliff. A tilt run is extended until the platform has held its
    # final tilt for scenario.hold_s.
    duration_s: float | None = Field(None, gt=1.0, le=120.0)
    friction: float = Field(1.5, gt=0.1, le=3.0)  # the paper assumes feet never slip
    control_dt: float = Field(0.02, ge=0.002, le=0.05)
    # Physics step. The default 1 ms is the convergence rule's choice: halving it moves the
    # recovered answers less than the stated tolerance (2 ms did not; docs/tipping.md).
    timestep_s: float = Field(HEAVY.timestep, ge=0.00025, le=0.002)

    @model_validator(mode="after")
    def _multiple_of_timestep(self):
        k = self.control_dt / self.timestep_s
        if abs(k - round(k)) > 1e-6:
            raise ValueError(f"control_dt {self.control_dt} must be a multiple of the physics step timestep_s "
                             f"{self.timestep_s} s")
        return self


class TippingEvidence(StrictModel):
    """What the job computes beside its answer (issue 12): the controls on the same
    scenario, the answer re-simulated under perturbations, and (tilting platform only) the
    survivable tilt band by bisection on real runs."""

    controls: bool = True
    robustness: bool = True
    band: bool = True
    band_min_deg: float = Field(10.0, ge=1.0, le=59.0)
    band_max_deg: float = Field(60.0, ge=2.0, le=60.0)
    band_tolerance_deg: float = Field(1.0, ge=0.1, le=10.0)
    # The recovery's target: upright to the end and, if a leg was caught, the FASM margin
    # 0.5 s after its landing at least this (0 = statically stable on the new support).
    target_margin_deg: float = Field(0.0, ge=0.0, le=60.0)

    @model_validator(mode="after")
    def _band_order(self):
        if self.band_min_deg + self.band_tolerance_deg > self.band_max_deg:
            raise ValueError(f"band_min_deg {self.band_min_deg} + band_tolerance_deg {self.band_tolerance_deg} "
                             f"exceeds band_max_deg {self.band_max_deg}")
        return self

    def plan(self) -> EvidencePlan:
        return EvidencePlan(controls=self.controls, robustness=self.robustness, band=self.band,
                            band_lo_deg=self.band_min_deg, band_hi_deg=self.band_max_deg,
                            band_tol_deg=self.band_tolerance_deg, target_margin_deg=self.target_margin_deg)


class TippingSweep(StrictModel):
    enabled: bool = False
    directions: int = Field(12, ge=1, le=36)
    stances: list[Tripod] = Field(default_factory=lambda: [[1, 3, 5], [2, 4, 6]], min_length=1, max_length=2)

    @field_validator("stances")
    @classmethod
    def _tripods(cls, v):
        return [_check_tripod(s) for s in v]


class TippingSpec(SpecBase):
    kind: Literal["tipping"] = "tipping"
    robot: Literal["heavy_hexapod"] = "heavy_hexapod"
    scenario: Annotated[Union[TiltIn, CliffIn], Field(discriminator="type")] = Field(default_factory=TiltIn)
    detector: TippingDetector = Field(default_factory=TippingDetector)
    recovery: TippingRecovery = Field(default_factory=TippingRecovery)
    sim: TippingSim = Field(default_factory=TippingSim)
    sweep: TippingSweep = Field(default_factory=TippingSweep)
    evidence: TippingEvidence = Field(default_factory=TippingEvidence)
    seed: int = Field(0, ge=0, le=2**32 - 1)  # recorded; the scenarios draw nothing at random

    @model_validator(mode="after")
    def _sweep_needs_tilt(self):
        if self.sweep.enabled and self.scenario.type != "tilt":
            raise ValueError("sweep: the direction sweep turns the tilting platform; scenario.type must be 'tilt'")
        return self

    budget_field: ClassVar[str] = "sweep.directions"
    budget_formula: ClassVar[str] = (
        "simulations, each counted once: 1 without recovery; with recovery on, + 1 with it, + 3 controls (no QP, position-servoed "
        "stance, fixed swing time) when evidence.controls; + 7 robustness re-runs (step halved and quartered, "
        "friction x0.7 and x1.3, masses +-10 %, payload) when evidence.robustness; + 2 x (2 + "
        "ceil(log2((band_max - band_min) / band_tolerance))) bisection probes (with and without recovery) when "
        "evidence.band on the tilting platform (only 1 for a controller that already tips at band_min, 2 for one that "
        "still stands at band_max); + 2 x directions x stances when the sweep is on")

    @property
    def evaluations_budget(self) -> int:
        return sum(self.phase_sizes().values())

    def phase_sizes(self) -> dict[str, int]:
        """Simulations per phase of the job, in the order they run (at most: the band's
        bisection may stop early)."""
        sizes = {"runs": 2 if self.recovery.enabled else 1}
        if self.recovery.enabled:
            sizes |= self.evidence.plan().sizes(self.scenario.type == "tilt")
        if self.sweep.enabled:
            sizes["sweep"] = 2 * self.sweep.directions * len(self.sweep.stances)
        return sizes

    def duration(self) -> float:
        if self.sim.duration_s is not None:
            return self.sim.duration_s
        return 20.0 if self.scenario.type == "tilt" else 32.0

    def geometry(self):
        return dataclasses.replace(HEAVY, timestep=self.sim.timestep_s)

    def controller(self, recovery: bool) -> ControllerConfig:
        r = self.recovery
        return ControllerConfig(recovery=recovery, threshold_deg=self.detector.threshold_deg, kappa=self.detector.kappa,
                                rho=r.safety_margin, lam=r.cone_lambda, mu=r.mu_qp, swing_min_s=r.swing_min_s,
                                swing_max_s=r.swing_max_s, clearance_m=r.clearance_m, qp=r.qp,
                                control_dt=self.sim.control_dt, max_adjustments=r.max_adjustments,
                                swing_timing=r.swing_timing, fixed_swing_s=r.fixed_swing_s,
                                stance_control=r.stance_control, compliance=r.compliance,
                                posture_hz=r.posture_hz)


Spec = TippingSpec

"""The ``tipping`` spec (paper 002): the scenario (tilting platform or cliff walk),
detector, recovery controller, simulation and the optional direction sweep."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal, Union

from pydantic import Field, field_validator, model_validator

from app.jobs.base import SpecBase, StrictModel
from app.robots.heavy_hexapod import HEAVY, TRIPODS
from app.stability.scenario import CliffScenario, ControllerConfig, TiltScenario, paper_direction

Tripod = list[Annotated[int, Field(ge=1, le=6)]]


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


class TippingSim(StrictModel):
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
    seed: int = Field(0, ge=0, le=2**32 - 1)  # recorded; the scenarios draw nothing at random

    @model_validator(mode="after")
    def _sweep_needs_tilt(self):
        if self.sweep.enabled and self.scenario.type != "tilt":
            raise ValueError("sweep: the direction sweep turns the tilting platform; scenario.type must be 'tilt'")
        return self

    budget_formula: ClassVar[str] = ("2 simulated runs (without and with recovery), + 2 x directions x stances "
                                     "when the sweep is on")

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

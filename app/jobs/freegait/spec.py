"""The ``freegait`` spec (paper 004): the route, the terrain, the minefield, the gait
planner's parameters (Sec. 5 defaults) and which evidence runs to add."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from app.jobs import evidence
from app.jobs.base import SpecBase, SpecError, StrictModel
from app.jobs.evidence import Case, Target
from app.jobs.freegait.planner.params import GaitParams
from app.jobs.freegait.planner.route import Change, Route
from app.jobs.freegait.planner.search import MAX_TRIPODS
from app.robots.silo6 import SILO6

START_X = 1.0  # the robot starts this far from the terrain's rear edge (x = 0 is its start)
FOOTPRINT_M = 0.85  # body centre to the farthest point of a foot's workspace (0.49, 0.65)
MAX_CRAB_DEG = 45.0  # Sec. 2.2 names the front, centre and rear leg of a tripod: they keep those roles up to 45 deg
MAX_DURATION_S = 900.0


class ChangeIn(StrictModel):
    """A timed change of the commanded crab angle or of k_ev (the paper's examples 1 and 3)."""

    at_s: float = Field(ge=0.0, le=MAX_DURATION_S)
    crab_angle_deg: float | None = Field(None, ge=-MAX_CRAB_DEG, le=MAX_CRAB_DEG)
    k_ev: float | None = Field(None, ge=0.0, le=20.0)

    @model_validator(mode="after")
    def _something(self):
        if self.crab_angle_deg is None and self.k_ev is None:
            raise ValueError("a change sets crab_angle_deg, k_ev or both")
        return self


class RouteIn(StrictModel):
    gait: Literal["crab", "circling", "spinning"] = "crab"
    crab_angle_deg: float = Field(0.0, ge=-MAX_CRAB_DEG, le=MAX_CRAB_DEG,
                                  description="angle between the body's x axis and the direction of motion")
    speed_m_s: float = Field(0.02, ge=0.0, le=SILO6.max_speed, description="V_BHN; 0 for spinning")
    distance_m: float = Field(2.0, gt=0.0, le=20.0, description="COG path length (crab, circling)")
    turn_rate_deg_s: float = Field(0.0, ge=-5.0, le=5.0, description="yaw rate (circling, spinning)")
    turn_deg: float = Field(90.0, gt=0.0, le=720.0, description="yaw to turn (spinning)")
    changes: list[ChangeIn] = Field(default_factory=list, max_length=20)

    def build(self) -> Route:
        return Route(gait=self.gait, crab_angle_deg=self.crab_angle_deg, speed=self.speed_m_s, distance=self.distance_m,
                     turn_rate_deg_s=self.turn_rate_deg_s, turn_deg=self.turn_deg,
                     changes=tuple(Change(c.at_s, c.crab_angle_deg, c.k_ev) for c in self.changes))


class TerrainIn(StrictModel):
    roughness_m: float = Field(0.04, ge=0.0, le=0.09, description="peak-to-valley height of the ground (I_T)")
    seed: int = Field(0, ge=0, le=2**32 - 1)
    length_m: float = Field(4.0, ge=2.5, le=20.0)
    width_m: float = Field(4.0, ge=2.5, le=12.0)

    def x_range(self) -> tuple[float, float]:
        return (-START_X, self.length_m - START_X)

    def y_range(self) -> tuple[float, float]:
        return (-self.width_m / 2, self.width_m / 2)


class ForbiddenIn(StrictModel):
    density_per_m2: float = Field(3.0, ge=0.0, le=20.0)
    zone_diameter_m: float = Field(0.05, gt=0.0, le=0.3)
    safe_diameter_m: float = Field(0.15, gt=0.0, le=0.5)
    known: bool = True
    seed: int = Field(0, ge=0, le=2**32 - 1)

    @model_validator(mode="after")
    def _safe_covers_zone(self):
        if self.safe_diameter_m < self.zone_diameter_m:
            raise ValueError(f"safe_diameter_m {self.safe_diameter_m} is smaller than zone_diameter_m "
                             f"{self.zone_diameter_m}; the safe area surrounds the zone")
        return self


class PlannerIn(StrictModel):
    sm_min_m: float = Field(0.05, ge=0.0, le=0.3, description="SM_min (Def. 2)")
    k_ev: float = Field(0.04, ge=0.0, le=20.0, description="weight of SM_t in Ev = K + k_ev SM_t (Eq. 24)")
    candidates_per_leg: int = Field(15, json_schema_extra={"minimum": 2, "maximum": int(MAX_TRIPODS ** (1 / 3) + 1e-9)},
                                    description=f"N, 2 or more; all N^3 tripods are checked, N^3 <= {MAX_TRIPODS}")
    h1_m: float = Field(0.13, gt=0.0, le=0.3)
    h2_m: float = Field(0.11, ge=0.0, le=0.3)
    h3_m: float = Field(0.20, gt=0.0, le=0.3)
    v1_m_s: float = Field(0.10, gt=0.0, le=0.5)
    v2_m_s: float = Field(0.30, gt=0.0, le=1.0)
    v3_m_s: float = Field(0.10, gt=0.0, le=0.5)

    @field_validator("candidates_per_leg")
    @classmethod
    def _n(cls, v: int) -> int:
        if v < 2:
            raise ValueError(f"{v}: at least 2 candidates per leg")
        if v**3 > MAX_TRIPODS:
            raise ValueError(f"{v}: N^3 = {v**3} tripods exceeds the cap of {MAX_TRIPODS} (N <= {round(MAX_TRIPODS ** (1 / 3))})")
        return v

    def build(self) -> GaitParams:
        return GaitParams(sm_min=self.sm_min_m, k_ev=self.k_ev, n_candidates=self.candidates_per_leg, h1=self.h1_m,
                          h2=self.h2_m, h3=self.h3_m, v1=self.v1_m_s, v2=self.v2_m_s, v3=self.v3_m_s)


class EvidenceIn(StrictModel):
    controls: bool = True
    robustness: bool = True


def max_speed(p: GaitParams, stroke: float = SILO6.stroke) -> float:
    """Fastest V_BH at which support conditions 3 and 4 can hold at all: a new foothold
    needs K > L + R_e > R_3 + R_e, K <= R_x - R_1, and R_e = m (R_1 + R_x V/V_2 + R_3)."""
    t1, t3 = p.h1 / p.v1, p.h3 / p.v3
    return stroke / (t1 + t3 + p.re_margin * (t1 + stroke / p.v2 + t3))


class FreegaitSpec(SpecBase):
    kind: Literal["freegait"] = "freegait"
    robot: Literal["silo6"] = "silo6"
    seed: int = Field(0, ge=0, le=2**32 - 1, description="the random-valid-tripod control draws from it")
    route: RouteIn = Field(default_factory=RouteIn)
    terrain: TerrainIn = Field(default_factory=TerrainIn)
    forbidden: ForbiddenIn = Field(default_factory=ForbiddenIn)
    planner: PlannerIn = Field(default_factory=PlannerIn)
    evidence: EvidenceIn = Field(default_factory=EvidenceIn)

    budget_formula: ClassVar[str] = (
        "1 walk, plus 3 control walks on the same field when evidence.controls (zone-unaware planner, periodic tripod "
        "with fixed footholds, a random valid tripod instead of the best Ev), plus 7 re-simulations of the walk when "
        "evidence.robustness (ground-height estimate +-I_T/2, friction x0.7 and x1.3, masses +10 %, timestep halved "
        "and quartered)")

    @property
    def evaluations_budget(self) -> int:
        return 1 + (3 if self.evidence.controls else 0) + (len(ROBUSTNESS_CASES) if self.evidence.robustness else 0)

    @classmethod
    def parse(cls, data):
        """Field checks by pydantic, then the checks that span sections, each naming its field."""
        spec = super().parse(data)
        errors = spec.cross_errors()
        if errors:
            raise SpecError(errors)
        return spec

    def cross_errors(self) -> list[dict[str, str]]:
        r, p = self.route, self.planner.build()
        errs: list[dict[str, str]] = []

        def err(field: str, message: str) -> list[dict[str, str]]:
            errs.append({"field": field, "message": message})
            return errs

        if r.gait == "spinning":
            if r.speed_m_s != 0.0:
                return err("route.speed_m_s", "a spinning gait turns in place: set 0")
            if r.turn_rate_deg_s == 0.0:
                return err("route.turn_rate_deg_s", "a spinning gait needs a non-zero yaw rate (-5..5 deg/s)")
        else:
            vmax = max_speed(p)
            if not 0.005 <= r.speed_m_s <= vmax:
                return err("route.speed_m_s",
                           f"{r.speed_m_s} outside [0.005, {vmax:.4f}] m/s: with these transfer parameters support "
                           "conditions 3 and 4 cannot both hold above R_x / (H1/V1 + H3/V3 + 1.15 (H1/V1 + R_x/V2 + H3/V3))")
            if r.gait == "circling" and r.turn_rate_deg_s == 0.0:
                return err("route.turn_rate_deg_s", "a circling gait needs a non-zero yaw rate (-5..5 deg/s)")
            if r.gait == "crab" and r.turn_rate_deg_s != 0.0:
                return err("route.turn_rate_deg_s", "a crab gait does not turn: set 0 or use gait 'circling'")
        route = r.build()
        if route.nominal_duration() > MAX_DURATION_S:
            return err("route.distance_m", f"the route would take {route.nominal_duration():.0f} s without stops; "
                                           f"at most {MAX_DURATION_S:.0f} s")
        if self.terrain.roughness_m >= p.h3 / 2:
            err("terrain.roughness_m", f"{self.terrain.roughness_m} must stay below H3/2 = {p.h3 / 2:g} m "
                                       "(Sec. 2.3: H3/2 > I_T, the ground-height uncertainty)")
        path = route.nominal_path()
        (x0, x1), (y0, y1) = self.terrain.x_range(), self.terrain.y_range()
        m = FOOTPRINT_M
        out = (path[:, 0] - m < x0) | (path[:, 0] + m > x1) | (path[:, 1] - m < y0) | (path[:, 1] + m > y1)
        if out.any():
            k = int(np.argmax(out))
            err("route", f"the robot would leave the terrain (x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}] m) at "
                         f"({path[k, 0]:.2f}, {path[k, 1]:.2f}) m after {k * 0.1:.0f} s; shorten route.distance_m or "
                         "enlarge terrain.length_m / terrain.width_m")
        for i, c in enumerate(r.changes):
            if c.at_s > route.nominal_duration() * 4:
                err(f"route.changes.{i}.at_s", f"{c.at_s} s is after the walk can have ended")
        return errs

    def params(self) -> GaitParams:
        return self.planner.build()


# -- the evidence: the target every walk is judged by, the robustness cases ----------------

def target_parts(m: Mapping[str, Any], sm_min: float) -> dict[str, bool | None]:
    """The target's three parts judged on a walk's metrics (the SM part None when no SM
    was measured), so that the headline can show each beside its value."""
    sm = m.get("min_sm_m")
    return {"finished": bool(m.get("finished")), "no_zone_footholds": m.get("footholds_in_zones") == 0,
            "sm_above_min": None if sm is None else sm > sm_min}


def _reached(m: Mapping[str, Any]) -> bool:
    return all(target_parts(m, m["sm_min_m"]).values())


TARGET = Target("finishes the route, 0 footholds in forbidden zones, SM > SM_min throughout", _reached)
"""Judges metrics that carry the SM_min the walk was planned with (``sm_min_m``, as the
job's summary does); ``target_met`` adds it to a walk's own metrics."""


def target_met(metrics: Mapping[str, Any], sm_min: float) -> bool:
    return TARGET.met({**metrics, "sm_min_m": sm_min})


@dataclasses.dataclass(frozen=True)
class GroundError(Case):
    """The kind's own robustness case: the planner's estimate of the ground height under a
    new foothold off by ``sign`` x I_T/2 (the walk's ``ground_bias``), the uncertainty
    Sec. 2.3 sizes H3 for."""

    sign: float = 0.0


# the kind's labels kept (they are what every stored summary shows)
ROBUSTNESS_CASES: tuple[Case, ...] = (
    GroundError("ground_error_+", "planner's ground estimate I_T/2 too high", sign=1.0),
    GroundError("ground_error_-", "planner's ground estimate I_T/2 too low", sign=-1.0),
    evidence.case("friction_0.7", "friction x0.7"),
    evidence.case("friction_1.3", "friction x1.3"),
    evidence.case("mass_+10pct", "every mass +10 %"),
    evidence.case("dt_half", "physics timestep halved (1 ms)"),
    evidence.case("dt_quarter", "physics timestep quartered (0.5 ms)"),
)

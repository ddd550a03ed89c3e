"""The ``repertoire`` spec: a MAP-Elites map of gaits (Cully et al., Nature 2015) for a
robot with a leg map, built-in or uploaded, intact or under a stated damage.

Every number has bounds, every list a length cap; no type coercion; finite numbers only.
The choices where the paper or the issue is silent are stated in docs/repertoire.md."""

from __future__ import annotations

import re
from typing import Annotated, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from app.jobs.base import SpecBase, SpecError, StrictModel
from app.robots.damage import Damage as RobotDamage

BUILTIN = ("jethexa",)  # the built-in robots with a leg map (app/robots/catalog.py)
ROBOT_ID = r"^[0-9a-f]{32}$"  # an uploaded robot's id (app/store/robots.py)
Metres = Annotated[float, Field(ge=-100.0, le=100.0)]
# The largest step the map's convergence rule accepts (docs/repertoire.md, "Timestep", measured by
# `gaitmend reproduce repertoire-timestep`): halving it moves the best elites' median forward distance by
# < 5 % and keeps >= 80 % of them in their cell, on every seed. 2 ms passes; 3 and 4 ms do not.
TIMESTEP_S = 0.002


class Damage(RobotDamage):
    """The damage the map is built for, in the one vocabulary of app/robots/damage.py, by the
    leg map's names (jethexa: legs leg1..leg6, odd left, even right, front to back; joints
    leg<n>_coxa, _femur, _tibia): lost legs, locked, weak, passive and stiff joints, shortened
    legs. ``{}``: intact."""

    ALWAYS: ClassVar[tuple[str, ...]] = ("lost_legs", "locked_joints")  # a dump holds the others once used


Period = Annotated[float, Field(ge=0.05, le=10.0)]


class Controller(StrictModel):
    """The periodic joint-space controller (app/jobs/repertoire/controller.py): per driven
    joint an amplitude, a phase and an offset, and one shared period."""

    period_s: tuple[Period, Period] = Field((0.4, 1.2), description="the gait period's range (s): lo < hi")
    amplitude: float = Field(0.5, gt=0.0, le=1.0, description="largest amplitude, a fraction of each joint's half range")
    offset: float = Field(0.25, ge=0.0, le=1.0, description="largest offset from the stance, a fraction of each "
                                                            "joint's half range")
    ramp_s: float = Field(0.5, ge=0.0, le=5.0, description="the gait fades in from the stance over this time (s)")

    @field_validator("period_s")
    @classmethod
    def _ordered(cls, v):
        if not v[0] < v[1]:
            raise ValueError(f"bounds reversed or empty: lo {v[0]} must be below hi {v[1]}")
        return v


class Descriptor(StrictModel):
    """The behaviour a map spreads its gaits over. ``contact_share`` (ITE's): per remaining
    leg, the share of the trial's steps its foot touches the ground, each in [0, 1].
    ``displacement``: the final forward and lateral displacement of the centre of mass in
    the robot's start frame, within ``forward_m`` x ``lateral_m`` (values outside are
    clipped to the bounds)."""

    type: Literal["contact_share", "displacement"] = "contact_share"
    forward_m: tuple[Metres, Metres] = Field((-0.5, 0.5), description="displacement: forward bounds (m), lo < hi")
    lateral_m: tuple[Metres, Metres] = Field((-0.5, 0.5), description="displacement: lateral bounds (m), lo < hi")

    @field_validator("forward_m", "lateral_m")
    @classmethod
    def _ordered(cls, v):
        if not v[0] < v[1]:
            raise ValueError(f"bounds reversed or empty: lo {v[0]} must be below hi {v[1]}")
        return v


class Archive(StrictModel):
    cells: int = Field(2000, ge=2, le=100_000, description="centroids of the CVT archive")
    min_forward_m: float = Field(-1.0, ge=-100.0, le=0.0, description=(
        "the lowest forward distance (m) a gait may have to enter the map, and the QD-score's offset"))
    admit_fallen: bool = Field(False, description="whether a gait that fell may enter the map")
    centroid_seed: int | None = Field(None, ge=0, le=2**31 - 1, description=(
        "the seed of the centroids (null: the job's seed); the islands of one map share their base spec's, so "
        "their elites merge cell for cell (app/jobs/repertoire/merge.py)"))


class Search(StrictModel):
    """MAP-Elites through pyribs: one emitter proposing ``batch_size`` gaits per iteration
    (the first iteration: uniform random gaits)."""

    iterations: int = Field(100, ge=1, le=100_000)
    batch_size: int = Field(100, ge=1, le=4096)
    emitter: Literal["iso_line", "gaussian"] = Field("iso_line", description=(
        "iso_line: Vassiliades & Mouret's Iso+LineDD (ribs IsoLineEmitter); gaussian: MAP-Elites' Gaussian mutation "
        "(ribs GaussianEmitter)"))
    iso_sigma: float = Field(0.2, gt=0.0, le=1.0, description=(
        "iso_line: isotropic step (unit-cube units); the default won `gaitmend reproduce repertoire-emitter` "
        "(docs/repertoire.md)"))
    line_sigma: float = Field(0.2, ge=0.0, le=5.0, description="iso_line: step along the line between two elites")
    sigma: float = Field(0.1, gt=0.0, le=1.0, description="gaussian: mutation step (unit-cube units)")
    checkpoint_every: int = Field(10, ge=1, le=100_000, description="iterations between checkpoints")


class Sim(StrictModel):
    duration_s: float = Field(3.0, gt=0.0, le=60.0, description="a trial's walking time (s), after the settling")
    settle_s: float = Field(0.5, ge=0.0, le=5.0, description="the robot stands in its stance first (s)")
    timestep_s: float = Field(TIMESTEP_S, ge=0.0002, le=0.01, description="the simulation step (s)")

    @field_validator("duration_s")
    @classmethod
    def _not_zero(cls, v):
        if not v > 0:
            raise ValueError("a trial must last longer than 0 s")
        return v


class Evidence(StrictModel):
    random_control: bool = Field(True, description="a uniform random search at the same budget, into the same archive")
    rescore_elites: int = Field(20, ge=0, le=10_000, description="best elites re-scored at half the timestep")


class RepertoireSpec(SpecBase):
    kind: Literal["repertoire"] = "repertoire"
    robot: str = Field("jethexa", max_length=64, json_schema_extra={"enum": list(BUILTIN)}, description=(
        "a built-in robot with a leg map (the enum), or the id of one of your uploaded robots"))
    seed: int = Field(0, ge=0, le=2**31 - 1)
    damage: Damage = Field(default_factory=Damage)
    controller: Controller = Field(default_factory=Controller)
    descriptor: Descriptor = Field(default_factory=Descriptor)
    archive: Archive = Field(default_factory=Archive)
    search: Search = Field(default_factory=Search)
    sim: Sim = Field(default_factory=Sim)
    evidence: Evidence = Field(default_factory=Evidence)

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, v: str) -> str:
        if v not in BUILTIN and not re.fullmatch(ROBOT_ID, v):
            raise ValueError(f"unknown robot {v!r}: a repertoire needs a robot with a leg map: {list(BUILTIN)} "
                             "or the id of one of your uploaded robots (32 hex digits, GET /api/robots)")
        return v

    @model_validator(mode="after")
    def _damage_fits_the_builtin(self):
        if self.robot in BUILTIN:
            from app.jobs.repertoire.body import builtin_damage_error

            err = builtin_damage_error(self.robot, self.damage)
            if err:
                raise ValueError(err)
        return self

    @classmethod
    def parse(cls, data):
        """As SpecBase.parse; an error a whole-spec check raises as "<field>: ..." names that field."""
        try:
            return super().parse(data)
        except SpecError as e:
            errors = []
            for err in e.errors:
                m = re.match(r"^([a-z_]+(?:\.[a-z_]+)*): (.*)$", err["message"], flags=re.S)
                errors.append({"field": m.group(1), "message": m.group(2)} if err["field"] == "spec" and m else err)
            raise SpecError(errors) from None

    budget_field: ClassVar[str] = "search.iterations"
    budget_formula: ClassVar[str] = (
        "iterations x batch_size gaits for MAP-Elites, the same again for the random-search control when it is on, "
        "plus evidence.rescore_elites re-scorings at half the timestep and one recorded walk of the best gait")

    @property
    def evaluations_budget(self) -> int:
        search = self.search.iterations * self.search.batch_size
        return search * (2 if self.evidence.random_control else 1) + self.evidence.rescore_elites + 1


Spec = RepertoireSpec

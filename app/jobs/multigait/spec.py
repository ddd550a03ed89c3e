"""The ``multigait`` spec (paper 001): modular robot and its stuck modules, number of
gaits, cost (coverage or distance), map, PSO/DE search, planner, reuse experiment and
tree verification; every default is the paper's."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from app.jobs.base import SpecBase, StrictModel
from app.planning.maps import MAPS
from app.robots.modular import SHAPES



class Damage(StrictModel):
    stuck_modules: list[int] = Field(default_factory=list)

    @field_validator("stuck_modules")
    @classmethod
    def _unique(cls, v: list[int]) -> list[int]:
        if len(set(v)) != len(v):
            raise ValueError("each module may be listed once")
        if any(m < 0 for m in v):
            raise ValueError("module indices start at 0")
        return sorted(v)


class Search(StrictModel):
    optimizer: Literal["pso", "de"] = "pso"
    particles: int = Field(20, ge=2, le=1000)
    generations: int = Field(150, ge=1, le=10000)
    w: float = Field(0.1, ge=0.0, le=2.0)
    phi1: float = Field(2.0, ge=0.0, le=4.0)
    phi2: float = Field(2.0, ge=0.0, le=4.0)
    cr: float = Field(0.6, ge=0.0, le=1.0)
    f: float = Field(0.5, ge=0.0, le=1.0)
    seed: int = Field(0, ge=0, le=2**32 - 1)

    @model_validator(mode="after")
    def _de_needs_four(self):
        if self.optimizer == "de" and self.particles < 4:
            raise ValueError("particles: DE needs at least 4 (current-to-best/1 uses two other members)")
        return self


class Planner(StrictModel):
    iterations: int | None = Field(None, ge=1, le=2000)  # K_max; paper: 150 coverage / 100 distance
    goal_distance_mu: float = Field(15.0, gt=0.0, le=30.0)  # goal ahead of the start (flat maps)


class Reuse(StrictModel):
    """Sec. V-C: plan with the evolved gaits to a goal 30 mu away, K = 100 (Tables III-IV)."""

    enabled: bool = True
    plans: int = Field(20, ge=1, le=500)
    iterations: int = Field(100, ge=1, le=2000)
    distance_mu: float = Field(30.0, gt=0.0, le=40.0)


class Verify(StrictModel):
    """How many nodes of the best tree are replayed in full simulation."""

    nodes: int = Field(60, ge=0, le=2000)


class MultigaitSpec(SpecBase):
    kind: Literal["multigait"] = "multigait"
    robot: str = "lizard"
    damage: Damage = Field(default_factory=Damage)
    gaits: int | None = Field(None, ge=1, le=6)  # paper: 3 (2 on the staircase)
    cost: Literal["coverage", "distance"] = "coverage"
    map: str = "empty"
    search: Search = Field(default_factory=Search)
    planner: Planner = Field(default_factory=Planner)
    reuse: Reuse = Field(default_factory=Reuse)
    verify: Verify = Field(default_factory=Verify)
    gait_duration_s: float = Field(30.0, gt=0.0, le=120.0)  # tau^p
    settle_s: float = Field(1.0, ge=0.0, le=10.0)

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, v: str) -> str:
        if v not in SHAPES:
            raise ValueError(f"unknown modular robot {v!r}; allowed: {sorted(SHAPES)}")
        return v

    @field_validator("map")
    @classmethod
    def _known_map(cls, v: str) -> str:
        if v not in MAPS:
            raise ValueError(f"unknown map {v!r}; allowed: {sorted(MAPS)}")
        return v

    @model_validator(mode="after")
    def _stuck_exist(self):
        shape = SHAPES[self.robot]
        bad = [m for m in self.damage.stuck_modules if m >= shape.m]
        if bad:
            raise ValueError(f"damage.stuck_modules: {bad} not in the {self.robot}'s modules 0..{shape.m - 1}")
        if len(self.damage.stuck_modules) >= shape.m:
            raise ValueError("damage.stuck_modules: at least one module must work")
        return self

    @property
    def seed(self) -> int:
        return self.search.seed

    @property
    def k(self) -> int:
        return self.gaits if self.gaits is not None else (3 if MAPS[self.map].flat else 2)

    @property
    def iterations(self) -> int:
        if self.planner.iterations is not None:
            return self.planner.iterations
        return 150 if (self.cost == "coverage" or not MAPS[self.map].flat) else 100

    budget_formula: ClassVar[str] = ("particles x generations gait sets, each scored by one RRT-MP plan "
                                     "(generation 1 is the initial swarm)")

    @property
    def evaluations_budget(self) -> int:
        return self.search.particles * self.search.generations


Spec = MultigaitSpec

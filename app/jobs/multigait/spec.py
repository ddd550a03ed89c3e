"""The ``multigait`` spec (paper 001): modular robot and its stuck modules, number of
gaits, cost (coverage or distance), map, PSO/DE search, planner, reuse experiment, tree
verification, controls and robustness; every default is the paper's.

The evaluation budget counts the work of every phase (``budget_formula``), and a spec
whose total exceeds ``MAX_BUDGET`` units is refused with the formula in the message."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from app.jobs.base import SpecBase, StrictModel
from app.jobs.loop import StopRules
from app.optim.pso import PRESETS
from app.jobs.multigait.evidence import CASES
from app.jobs.multigait.planner.maps import MAPS
from app.robots.modular import SHAPES

MAX_BUDGET = 2_000_000


class Damage(StrictModel):
    stuck_modules: list[Annotated[int, Field(ge=0, le=63)]] = Field(default_factory=list, max_length=64)

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
    # PSO coefficients: a preset (app/optim/pso.py), each number overridable
    pso: Literal["paper", "constriction"] = "paper"
    w: float | None = Field(None, ge=0.0, le=2.0)
    phi1: float | None = Field(None, ge=0.0, le=4.0)
    phi2: float | None = Field(None, ge=0.0, le=4.0)
    vmax: float | None = Field(None, gt=0.0, le=1.0)  # |v| limit as a fraction of the box width
    cr: float = Field(0.6, ge=0.0, le=1.0)
    f: float = Field(0.5, ge=0.0, le=1.0)
    seed: int = Field(0, ge=0, le=2**32 - 1)

    @model_validator(mode="after")
    def _de_needs_four(self):
        if self.optimizer == "de" and self.particles < 4:
            raise ValueError("particles: DE needs at least 4 (current-to-best/1 uses two other members)")
        return self

    def pso_coefficients(self) -> dict[str, float]:
        c = dict(PRESETS[self.pso])
        for key in ("w", "phi1", "phi2", "vmax"):
            if getattr(self, key) is not None:
                c[key] = getattr(self, key)
        return c


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


class Controls(StrictModel):
    """Controls of the result: a random search with the same evaluator and planner draws at
    the search's budget, and the best gait sets planned again on fresh (held-out) draws."""

    random_search: bool = True
    heldout_plans: int = Field(20, ge=1, le=500)


class Robustness(StrictModel):
    """The best gait set re-simulated with the timestep halved and quartered, friction x 0.7
    and x 1.3, module masses -10 % and +10 % (app/jobs/multigait/evidence.py: CASES)."""

    enabled: bool = True


class MultigaitSpec(SpecBase):
    kind: Literal["multigait"] = "multigait"
    robot: str = Field("lizard", max_length=64, json_schema_extra={"enum": sorted(SHAPES)})
    damage: Damage = Field(default_factory=Damage)
    gaits: int | None = Field(None, ge=1, le=6)  # paper: 3 (2 on the staircase)
    cost: Literal["coverage", "distance"] = "coverage"
    map: str = Field("empty", max_length=64, json_schema_extra={"enum": sorted(MAPS)})
    search: Search = Field(default_factory=Search)
    stop: StopRules = Field(default_factory=StopRules)
    planner: Planner = Field(default_factory=Planner)
    reuse: Reuse = Field(default_factory=Reuse)
    verify: Verify = Field(default_factory=Verify)
    controls: Controls = Field(default_factory=Controls)
    robustness: Robustness = Field(default_factory=Robustness)
    gait_duration_s: float = Field(30.0, ge=1.0, le=120.0)  # tau^p; under 1 s a CPG gait moves nothing
    settle_s: float = Field(1.0, ge=0.0, le=10.0)

    @field_validator("robot", "map")
    @classmethod
    def _known(cls, v: str, info: ValidationInfo) -> str:
        what, known = {"robot": ("modular robot", SHAPES), "map": ("map", MAPS)}[info.field_name]
        if v not in known:
            raise ValueError(f"unknown {what} {v!r}; allowed: {sorted(known)}")
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

    @model_validator(mode="after")
    def _budget_fits(self):
        n = self.evaluations_budget
        if n > MAX_BUDGET:
            raise ValueError(f"evaluations_budget: {n} units exceed the limit of {MAX_BUDGET}; "
                             f"budget = {self.budget_formula}")
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

    budget_formula: ClassVar[str] = (
        "units of work over all phases: search.particles x (search.generations + 1) gait sets (the search; "
        "generation 0 is the initial swarm; each gait set simulated once and scored by one RRT-MP plan), the same number "
        "again for the random-search control (controls.random_search), 1 to re-examine the best gait set, "
        "controls.heldout_plans held-out plans of the best (twice with the random-search control: its best too), "
        "on flat maps verify.nodes single-gait re-simulations of the best tree and 3 x reuse.plans reuse plans "
        "(reuse.enabled), and 6 robustness re-simulations (robustness.enabled); one simulated gait set, one plan "
        "or one re-simulated tree node is one unit")

    def budget_parts(self) -> dict[str, int]:
        """Units per phase, in run order (their sum is ``evaluations_budget``)."""
        search = self.search.particles * (self.search.generations + 1)  # generation 0 is the initial swarm
        flat = MAPS[self.map].flat
        return {"search": search,
                "random_search": search if self.controls.random_search else 0,
                "examine": 1,
                "heldout": self.controls.heldout_plans * (2 if self.controls.random_search else 1),
                "verify": self.verify.nodes if flat else 0,
                "reuse": 3 * self.reuse.plans if (flat and self.reuse.enabled) else 0,
                "robustness": len(CASES) if self.robustness.enabled else 0}

    @property
    def evaluations_budget(self) -> int:
        return sum(self.budget_parts().values())


Spec = MultigaitSpec

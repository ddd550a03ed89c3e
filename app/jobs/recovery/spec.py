"""The ``recovery`` spec (paper 000): damage, DE search, objective weights, simulation,
gait and search-space bounds; every default is the paper's."""

from __future__ import annotations

import re
from typing import Annotated, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from app.jobs.recovery.sequences import InfeasibleMorphology, check_feasible
from app.jobs.base import SpecBase, StrictModel
from app.jobs.loop import StopRules
from app.optim.registry import MAXIMISERS, check_name
from app.robots.catalog import ROBOTS
from app.robots.damage import Damage as MapDamage
from app.robots.damage import LockedJointDamage, WeakJointDamage, damaged_once
from app.robots.hexapod import DEFAULT_TIMESTEP, joint_name, leg_name
from app.jobs.recovery.cases import CASE_NAMES
from app.jobs.recovery.robust import AGGREGATES, RANDOM_AGGREGATES

Leg = Annotated[int, Field(ge=1, le=6)]
JointName = Literal["coxa", "femur", "tibia"]
# Search-space bounds are positions and lengths at the foot: within a metre of the hip
# (a JetHexa leg reaches about 0.2 m), so a typo cannot ask for a gait in kilometres.
Metres = Annotated[float, Field(ge=-1.0, le=1.0)]
Range = tuple[Metres, Metres]


class LockedJointIn(StrictModel):
    leg: Leg
    joint: JointName
    angle_deg: float = Field(0.0, ge=-180.0, le=180.0)


class WeakJointIn(StrictModel):
    leg: Leg
    joint: JointName
    torque_scale: float = Field(0.5, gt=0.0, le=1.0)


class Damage(StrictModel):
    # The built-in hexapod's damage in the paper's spelling, legs by number (1..6) and joints
    # coxa/femur/tibia; ``named()`` is the robot layer's one vocabulary (app/robots/damage.py),
    # by the leg map's names, which the job applies.

    lost_legs: list[Leg] = Field(default_factory=list, max_length=6)
    locked_joints: list[LockedJointIn] = Field(default_factory=list, max_length=18)  # 6 legs x 3 joints
    weak_joints: list[WeakJointIn] = Field(default_factory=list, max_length=18)

    @field_validator("lost_legs")
    @classmethod
    def _unique(cls, v: list[int]) -> list[int]:
        if len(set(v)) != len(v):
            raise ValueError("each leg may be listed once")
        try:
            check_feasible([l for l in range(1, 7) if l not in v])
        except InfeasibleMorphology as e:
            raise ValueError(str(e)) from None
        return sorted(v)

    @model_validator(mode="after")
    def _joints_on_present_legs(self):
        damaged_once(self, ("locked_joints", "weak_joints"), str)
        return self

    def named(self) -> MapDamage:
        """The numbers translated to the built-in leg map's names (leg 2's femur: leg2, leg2_femur)."""
        return MapDamage(
            lost_legs=[leg_name(l) for l in self.lost_legs],
            locked_joints=[LockedJointDamage(leg=leg_name(j.leg), joint=joint_name(j.leg, j.joint), angle_deg=j.angle_deg)
                           for j in self.locked_joints],
            weak_joints=[WeakJointDamage(leg=leg_name(j.leg), joint=joint_name(j.leg, j.joint),
                                         torque_scale=j.torque_scale) for j in self.weak_joints])


ROBOT_ID = r"^[0-9a-f]{32}$"  # an uploaded robot's id (app/store/robots.py)


class RobotDamage(MapDamage):  # the robot layer's one vocabulary (app/robots/damage.py), as it is
    """An uploaded robot's damage by its leg map's names: lost legs, locked joints, weak
    joints (servo force limit scaled), passive joints (no servo: the joint swings freely
    with its damping) and shortened legs (the foot segment cut by a length)."""


class ShortWalks(StrictModel):
    """The first generations walk for less time: their F (by default of the short walk's
    displacements carried to the full walk) only ranks the candidates for CMA-ES, which uses
    nothing but the ranking; the answer is the best of the full-walk generations that follow
    (docs/recovery_speed.md)."""

    walk_s: float = Field(ge=3.0, le=120.0, description=(
        "the early generations' walk (s), at least 3 s (a shorter walk says nothing about straightness) and shorter "
        "than sim.duration_s"))
    generations: int = Field(ge=1, le=10000, description=(
        "how many generations, generation 0 included, walk for walk_s; at most search.generations, so that at least "
        "one generation walks in full"))
    extrapolate: bool = Field(True, description=(
        "the short walk's forward, lateral and yaw displacements carried to the full walk as rates (times "
        "sim.duration_s / walk_s) before F, so that a drift weighs as it would over the full walk; false: the short "
        "walk's own F"))


class Search(StrictModel):
    optimizer: str = Field("de", max_length=32, json_schema_extra={"enum": list(MAXIMISERS)}, description=(
        "any registered optimiser that maximises (app/optim/registry.py): de (the paper's), cmaes, pso, random; "
        "cr and f are DE's, the others keep their own defaults"))
    population: int = Field(30, ge=4, le=1000)
    generations: int = Field(60, ge=1, le=10000)
    cr: float = Field(0.6, ge=0.0, le=1.0)
    f: float = Field(0.5, ge=0.0, le=1.0)
    seed: int = Field(0, ge=0, le=2**32 - 1)
    cut_walks: bool = Field(False, description=(
        "DE only: end a trial's walk once its F can no longer reach its parent's, which DE's selection (Eq. 10) "
        "keeps either way; same answer as the full walks whenever the rule's speed cap holds (docs/recovery_speed.md)"))
    short_walks: ShortWalks | None = Field(None, description=(
        "CMA-ES only: the first generations walk for less time and only steer the search; the answer is the best of "
        "the full-walk generations (docs/recovery_speed.md)"))

    @field_validator("optimizer")
    @classmethod
    def _registered(cls, v: str) -> str:
        return check_name(v, maximise=True)  # F is maximised


class RecoveryStop(StopRules):
    at_target: bool = Field(False, description=(
        "stop once the best gait meets the recovery target (over the 10 s walk: forward >= 50 cm, |lateral| <= 5 cm, "
        "|yaw| <= 10 deg, no fall; as rates, scaled to the walk's length), confirmed by a walk at half the step; "
        "the time it took is reported (summary timing.time_to_target_s)"))


class Objective(StrictModel):
    weights: list[Annotated[float, Field(ge=0.0, le=1e6)]] = Field(default_factory=lambda: [1.0, 1.0, 10.0, 100.0, 100.0],
                                                           min_length=5, max_length=5)
    # Eq. 5 gives no units; Table II reports cm and degrees, and in those units the
    # weights do what the paper says they are for (docs/recovery.md, "Choices where the paper is silent").
    units: Literal["m_rad", "cm_deg"] = "cm_deg"


class Sim(StrictModel):
    duration_s: float = Field(10.0, ge=0.5, le=120.0)  # shorter than a few steps measures nothing
    settle_s: float = Field(0.5, ge=0.0, le=5.0)
    # The default passes the convergence rule (docs/recovery.md, "Timestep: the convergence rule"); coarser steps are allowed
    # for quick looks, and the robustness block shows what they cost.
    timestep_s: float = Field(DEFAULT_TIMESTEP, ge=0.0005, le=0.008)


CaseName = Literal[CASE_NAMES]  # type: ignore[valid-type]


def _unique_cases(v: list[str]) -> list[str]:
    if len(set(v)) != len(v):
        raise ValueError("each perturbation may be listed once")
    return v


class Choice(StrictModel):
    """Which of the search's gaits is the answer. ``best``: the best F on the nominal model
    (the paper). ``robust``: every member of DE's final population that meets the recovery
    target on the nominal model is walked on ``models`` random models drawn from the held-out
    set's ranges with a stream of the job's seed of its own (cases.CHOICE_STREAM: never the
    held-out set's, never a randomised search's), and the answer is the one that keeps the
    target on the most of them (then the fewest falls, then the best F); when none meets the
    target, the best F stays the answer."""

    mode: Literal["best", "robust"] = Field("best", description=(
        "best: the best F on the nominal model (the paper); robust: of DE's final population, the gait that meets "
        "the target on the nominal model and on the most random models drawn for the choice"))
    models: int = Field(20, ge=1, le=200, description="random models the robust choice walks each member on")


class Robust(StrictModel):
    """Robust search: every candidate is scored on the nominal model and on each of
    ``models`` (standard perturbations by name) in the same batched rollout, and its
    fitness is the mean or the worst of the Eq. 5 fitness over them."""

    models: list[CaseName] = Field(min_length=1, max_length=len(CASE_NAMES))
    aggregate: Literal[AGGREGATES] = "mean"  # type: ignore[valid-type]

    @field_validator("models")
    @classmethod
    def _unique(cls, v: list[str]) -> list[str]:
        return _unique_cases(v)


class Randomised(StrictModel):
    """Randomised robust search (app/jobs/recovery/randomised.py; DE only): each generation
    draws ``models`` random models from the stated ranges (cases.RANDOM_RANGES) with a stream
    of the job's seed and the generation's index (a resume draws the same), scores every
    candidate on all of them in one rollout, and its fitness is the mean of the Eq. 5 fitness
    over them, or the CVaR (the mean of the worst ceil(cvar_share x models)). DE's parents are
    scored again on each generation's draw (counted): a search costs population x models x
    (2 generations + 1) walks."""

    models: int = Field(4, ge=2, le=32, description="K: random models drawn per generation")
    aggregate: Literal[RANDOM_AGGREGATES] = "mean"  # type: ignore[valid-type]
    cvar_share: float = Field(0.5, ge=0.1, le=1.0, description=(
        "cvar: the share of the worst models averaged (ceil(share x K) of them)"))


class Controls(StrictModel):
    random_search: bool = True  # uniform sampling of the same bounds at the search's budget
    cut_walks: bool = Field(True, description=(
        "the random-search control ends a walk once its F can no longer beat the control's best so far: the same "
        "best as with full walks whenever the cut rule's speed cap holds (docs/recovery_speed.md), its history's "
        "mean and worst skip the cut walks; on the nominal model only (a robust or randomised control walks in full)"))


class Robustness(StrictModel):
    cases: list[CaseName] = Field(default_factory=lambda: list(CASE_NAMES), max_length=len(CASE_NAMES))
    held_out: int = Field(20, ge=0, le=200, description=(
        "random models the answer is judged on, drawn from stated ranges (friction, masses, payload and its place, "
        "servo torque and gains, rough floor: cases.RANDOM_RANGES) with a stream of the job's seed that no search "
        "draws from; reported apart from the named cases"))

    @field_validator("cases")
    @classmethod
    def _unique(cls, v: list[str]) -> list[str]:
        return _unique_cases(v)


class Gait(StrictModel):
    period_s: float = Field(0.6, ge=0.2, le=5.0)
    stance_height_m: float = Field(0.10, ge=0.05, le=0.16)
    step_depth_m: float = Field(0.0, ge=0.0, le=0.02)


class Control(StrictModel):
    """How the gait is driven. open_loop: the searched gait's set-points, repeated (paper 000,
    what Table II reproduces). closed_loop: the same gait with a heading and drift correction
    on top, as a robot would run it (app/jobs/recovery/gait_controller.py, the module the
    bundle ships): from the IMU's heading (and, with odometry, the lateral position) read
    once per gait period or phase, a stride difference between the left and right legs
    turns the robot back to its start heading and a sideways stride carries it back to its
    line. The search, the answer's scoring and the robustness re-runs all use the mode; the
    summary reports the answer both ways. The metre-valued gains and limits are for the
    JetHexa's stance height (0.10 m): an uploaded robot's are scaled by its stance height over
    that, as its search bounds are; the lateral and balance gains (metres per metre) are not."""

    mode: Literal["open_loop", "closed_loop"] = "open_loop"
    update: Literal["period", "phase"] = Field("period", description=(
        "when the correction reads its sensors and sets a new command (ramped in over the next interval): once "
        "per gait period, or once per phase (the period over the sequence's sigma phases)"))
    odometry: bool = Field(True, description=(
        "use the chassis' lateral position (odometry) for the drift correction; false: IMU heading only"))
    yaw_gain: float = Field(0.1, ge=0.0, le=1.0, description="stride difference (m) per radian of heading error")
    yaw_integral_gain: float = Field(0.02, ge=0.0, le=1.0, description=(
        "stride difference (m) per radian of heading error summed over the updates"))
    lateral_gain: float = Field(0.5, ge=0.0, le=5.0, description="sideways stride (m) per metre of lateral offset")
    lateral_integral_gain: float = Field(0.1, ge=0.0, le=5.0, description=(
        "sideways stride (m) per metre of lateral offset summed over the updates"))
    # The limits keep every tip inside the leg's workspace (tests/jobs/recovery/test_closedloop.py):
    # each leg's stride also stays inside the search's step-length bounds.
    stride_limit_m: float = Field(0.015, ge=0.0, le=0.03, description=(
        "largest stride difference (m); each leg's stride also stays inside the step-length bounds"))
    lateral_limit_m: float = Field(0.015, ge=0.0, le=0.03, description="largest sideways stride (m) per period")
    balance_gain: float = Field(0.0, ge=0.0, le=1.0, description=(
        "balance: each tip's height offset per metre the trunk over that foot is below level (from the IMU's roll "
        "and pitch; 0: off)"))
    balance_integral_gain: float = Field(0.0, ge=0.0, le=1.0, description=(
        "balance: each tip's height offset per metre below level summed over the updates"))
    balance_limit_m: float = Field(0.015, ge=0.0, le=0.03, description="largest tip height offset (m) of the balance")


class Bounds(StrictModel):
    """Overrides of the paper's X_min / X_max (Sec. IV-B); omitted entries keep the paper's."""

    x0_m: Range | None = None
    step_length_m: Range | None = None
    step_height_m: Range | None = None
    y0_m: dict[Literal["1", "2", "3", "4", "5", "6"], Range] = Field(default_factory=dict)
    neighbour_relaxation: float = Field(0.2, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _ordered(self):
        pairs = [("x0_m", self.x0_m), ("step_length_m", self.step_length_m), ("step_height_m", self.step_height_m)]
        pairs += [(f"y0_m.{k}", v) for k, v in self.y0_m.items()]
        for name, rng in pairs:
            if rng is not None and rng[0] > rng[1]:
                raise ValueError(f"{name}: lower bound {rng[0]} exceeds upper bound {rng[1]} (inverted bounds)")
        for name, rng in pairs[:3]:
            if rng is not None and rng[0] < 0:
                raise ValueError(f"{name}: bounds must be >= 0, got {list(rng)}")
        return self


# A preset sets the fields a spec leaves out (a field the spec gives wins); the spec as
# stored names the preset and holds every value, so it parses back to itself.
PRESETS: dict[str, dict] = {
    "paper": {},
    "fast": {"search": {"cut_walks": True}, "stop": {"at_target": True, "plateau_generations": 10}},
}
PRESET_TEXT = ("paper: every field as paper 000 (DE 30 x 60 over full 10 s walks, the whole budget; what Table II "
               "reproduces). fast: stops as soon as the best gait meets the recovery target, confirmed at half the "
               "step, or when the best F has not improved for 10 generations, and cuts short the walks of trials "
               "that can no longer win DE's selection (docs/recovery_speed.md); a field you set wins")


class RecoverySpec(SpecBase):
    kind: Literal["recovery"] = "recovery"
    preset: Literal[tuple(PRESETS)] = Field("paper", description=PRESET_TEXT)  # type: ignore[valid-type]
    robot: str = Field("jethexa", max_length=64, json_schema_extra={"enum": sorted(ROBOTS)}, description=(
        "a built-in robot (the enum), or the id of one of your uploaded robots (GET /api/robots; its damage is "
        "robot_damage)"))
    # One default for the API, the CLI and the dashboard: the paper's first case (Table II,
    # legs 1 and 6 lost). `"damage": {}` is the intact robot.
    damage: Damage = Field(default_factory=lambda: Damage(lost_legs=[1, 6]))
    robot_damage: RobotDamage | None = Field(None, description=(
        "the damage by the robot's leg map's leg and joint names, every type of the robot layer's vocabulary: an "
        "uploaded robot's damage, or a built-in robot's instead of `damage` (jethexa: legs leg1..leg6, joints "
        "leg<n>_coxa, _femur, _tibia)"))
    search: Search = Field(default_factory=Search)
    stop: RecoveryStop = Field(default_factory=RecoveryStop)
    objective: Objective = Field(default_factory=Objective)
    sim: Sim = Field(default_factory=Sim)
    gait: Gait = Field(default_factory=Gait)
    control: Control = Field(default_factory=Control)
    bounds: Bounds = Field(default_factory=Bounds)
    robust: Robust | None = None
    randomised: Randomised | None = Field(None, description=(
        "randomised robust search: K random models drawn per generation, fitness their mean or CVaR"))
    controls: Controls = Field(default_factory=Controls)
    robustness: Robustness = Field(default_factory=Robustness)
    choice: Choice = Field(default_factory=Choice)

    @model_validator(mode="after")
    def _preset(self):
        for section, values in PRESETS[self.preset].items():
            part = getattr(self, section)
            for name, value in values.items():
                if name not in part.model_fields_set:
                    setattr(part, name, value)
        return self

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, v: str) -> str:
        if v not in ROBOTS and not re.fullmatch(ROBOT_ID, v):
            raise ValueError(f"unknown robot {v!r}; allowed: {sorted(ROBOTS)} or the id of one of your uploaded "
                             "robots (32 hex digits, GET /api/robots)")
        return v

    @model_validator(mode="after")
    def _damage_of_the_robot(self):
        """An uploaded robot's damage is robot_damage (its ``damage`` defaults to none)."""
        uploaded = self.robot not in ROBOTS
        if uploaded and "damage" not in self.model_fields_set:
            self.damage = Damage()
        if not uploaded and self.robot_damage is not None:
            self._built_in_named_damage()
        if uploaded and self.damage != Damage():
            raise ValueError("damage: an uploaded robot's damage is `robot_damage`, by its leg map's names")
        if uploaded and self.gait.stance_height_m != Gait().stance_height_m:  # a stored spec holds the default
            raise ValueError("gait.stance_height_m: an uploaded robot walks at its own stance height (its leg map's "
                             "stance); leave it at its default")
        return self

    def _built_in_named_damage(self) -> None:
        """A built-in robot damaged by its leg map's names (the one vocabulary, every type):
        checked against its map, and its lost legs given to ``damage`` in the paper's numbers
        (which the gait planner and the search space read). ``damage`` set as well must say
        the same lost legs and nothing else: the damage is given once."""
        from app.robots.legmap import LegMapError
        from app.robots.walkable import leg_numbers

        legs = ROBOTS[self.robot].leg_map()
        try:
            self.robot_damage.check(legs)
        except LegMapError as e:
            raise ValueError(f"robot_damage: {e}") from None
        number = leg_numbers(legs)  # the map's own numbering (front to back, left first), as for uploaded robots
        lost = sorted(number[l] for l in self.robot_damage.lost_legs)
        try:
            check_feasible([l for l in ROBOTS[self.robot].legs if l not in lost])
        except InfeasibleMorphology as e:
            raise ValueError(f"robot_damage.lost_legs: {e}") from None
        derived = Damage(lost_legs=lost)
        if "damage" in self.model_fields_set and self.damage != derived:
            raise ValueError("damage: give a built-in robot's damage once, by number in `damage` or by name in "
                             f"`robot_damage` (with robot_damage, damage may only repeat its lost legs: {lost})")
        self.damage = derived

    @model_validator(mode="after")
    def _robust_choice(self):
        if self.choice.mode != "robust":
            return self
        if self.search.optimizer != "de":
            raise ValueError("choice.mode: robust chooses among DE's final population (search.optimizer de)")
        return self

    @model_validator(mode="after")
    def _randomised_alone(self):
        if self.randomised is None:
            return self
        if self.robust is not None:
            raise ValueError("randomised: a search is either robust over fixed models or randomised, not both")
        if self.search.optimizer != "de":
            raise ValueError("randomised: DE only (its parents are scored again on every generation's draw)")
        if self.search.cut_walks:
            raise ValueError("randomised: search.cut_walks is for the nominal model only; set it false")
        return self

    @model_validator(mode="after")
    def _short_walks(self):
        sw = self.search.short_walks
        if sw is None:
            return self
        if self.search.optimizer != "cmaes":
            raise ValueError("search.short_walks: CMA-ES only (DE's selection compares a trial's F with its parent's, "
                             "which a shorter walk would not measure alike)")
        if sw.walk_s >= self.sim.duration_s:
            raise ValueError(f"search.short_walks.walk_s: must be shorter than sim.duration_s ({self.sim.duration_s} s), "
                             f"got {sw.walk_s}")
        if sw.generations > self.search.generations:
            raise ValueError(f"search.short_walks.generations: at most search.generations ({self.search.generations}) "
                             f"so that at least one generation walks in full, got {sw.generations}")
        for name, on in (("robust", self.robust is not None), ("randomised", self.randomised is not None),
                         ("stop.at_target", self.stop.at_target)):
            if on:
                raise ValueError(f"search.short_walks: not with {name} (it judges the best so far, which the short "
                                 "walks do not measure)")
        return self

    budget_field: ClassVar[str] = "search.generations"
    budget_formula: ClassVar[str] = (
        "population x (generations + 1) candidate gaits (generation 0 is the initial population), each simulated "
        "on 1 + len(robust.models) models (randomised: population x K x (2 generations + 1) walks, the parents "
        "scored again on every generation's draw); the same again for the random-search control when it is on; "
        "plus one simulation per robustness case, one per held-out model and three re-scorings (best, baseline, "
        "random-search best); in closed loop, the answer once more without the correction on the nominal model, "
        "each case and each held-out model; with stop.at_target, at most two confirmation walks per generation "
        "(at the default step and at half of it); with choice.mode robust, population x (1 + choice.models) walks "
        "more")

    @property
    def seed(self) -> int:
        return self.search.seed

    @property
    def models_per_candidate(self) -> int:
        return 1 + (len(self.robust.models) if self.robust else 0)

    @property
    def search_walks(self) -> int:
        """Walks one search simulates: P x (G + 1) per model, or randomised P x K x (2G + 1)."""
        s = self.search
        if self.randomised is not None:
            return s.population * self.randomised.models * (2 * s.generations + 1)
        return s.population * (s.generations + 1) * self.models_per_candidate

    @property
    def evaluations_budget(self) -> int:
        search = self.search_walks
        confirm = 2 * (self.search.generations + 1) if self.stop.at_target else 0
        # closed loop: the answer again without the correction, on the nominal model, the cases and the held-out set
        again = 1 + len(self.robustness.cases) + self.robustness.held_out if self.control.mode == "closed_loop" else 0
        return (search * (2 if self.controls.random_search else 1) + len(self.robustness.cases) + 3 + confirm
                + self.robustness.held_out + again + self.choice_walks)

    @property
    def choice_walks(self) -> int:
        """Walks the robust choice adds: every member of the final population on the nominal
        model and on each of the choice's models."""
        return self.search.population * (1 + self.choice.models) if self.choice.mode == "robust" else 0


Spec = RecoverySpec

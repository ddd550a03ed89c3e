"""The simulated reality: the robot the adaptation is tried on in tests and evaluation, in
place of a lab. It is a robot, a damage and a perturbed world, none of which the method
sees; a trial plays one elite of a map on it and returns what a lab would measure.

- ``robot``: a built-in robot the repertoire kind serves (the kind's ``robots``), or the id
  of an uploaded robot (its model and leg map come from a loader: `gaitmend adapt` reads
  this machine's robots, `gaitmend robot add`; the evaluation prepares its own).
- ``damage``: the repertoire kind's damage, by the leg map's names: the one vocabulary of
  app/robots/damage.py (lost legs, locked, weak, passive and stiff joints, shortened legs);
  the model is the class itself, taken from the kind's spec, and it is checked against the
  robot by the kind's own spec validation.
- ``perturbation``: the world's departure from the nominal model, in app/sim/perturb.py's
  ``Perturbation`` terms (the same field names, turned into one): friction and mass scales,
  a payload on the trunk, a rough floor.

A trial is played by the repertoire kind (``Kind.play``: its body builder, controller and
batched evaluator, app/jobs/repertoire/play.py) at the map's controller settings, trial
length and timestep, so a map's elite on an intact, unperturbed reality measures what the
map recorded for it."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections.abc import Callable
from typing import Annotated, Any

import numpy as np
from pydantic import Field, PrivateAttr, ValidationError, field_validator

from app.adapt.maps import Repertoire
from app.adapt.methods import Map
from app.jobs.base import SpecError, StrictModel
from app.jobs.registry import get_kind
from app.sim.perturb import Perturbation
from app.sim.servos import ServoPerturbation

KIND = get_kind("repertoire")  # the kind whose gaits a reality plays
Damage = KIND.Spec.model_fields["damage"].annotation  # the kind's damage model, reused as is
Offset = Annotated[float, Field(ge=-0.2, le=0.2)]


class World(StrictModel):
    """app/sim/perturb.py ``Perturbation``'s fields a reality may set (the rest nominal), and
    the servos' strength and gains (app/sim/servos.py ``ServoPerturbation``)."""

    friction_scale: float = Field(1.0, ge=0.2, le=3.0, description="sliding friction of every geom, x")
    mass_scale: float = Field(1.0, ge=0.5, le=2.0, description="mass and inertia of every body, x (same motors)")
    payload_kg: float = Field(0.0, ge=0.0, le=5.0, description="a mass added to the trunk (kg)")
    payload_offset_m: tuple[Offset, Offset, Offset] = Field((0.0, 0.0, 0.0), description=(
        "the payload's place from the trunk's centre of mass (m)"))
    terrain_amplitude_m: float = Field(0.0, ge=0.0, le=0.02, description=(
        "rough floor: heights uniform in [-a, a] (m) on perturb.py's 50 cm grid; 0: the flat plane"))
    terrain_seed: int = Field(0, ge=0, le=2**31 - 1, description="the rough floor's draw")
    motor_strength: float = Field(1.0, ge=0.2, le=1.5, description="every servo's torque limit, x")
    servo_gain_scale: float = Field(1.0, ge=0.2, le=3.0, description="every servo's gains (kp, kd, ki), x")

    def perturbation(self) -> Perturbation:
        return ServoPerturbation("reality", "the simulated reality", **self.model_dump())


ROBOT_ID = r"^[0-9a-f]{32}$"  # an uploaded robot's id (the repertoire spec's)


class Reality(StrictModel):
    robot: str = Field("jethexa", max_length=64, description=(
        "a built-in robot the repertoire kind serves, or the id of an uploaded robot (32 hex digits)"))
    damage: Damage = Field(default_factory=Damage)
    perturbation: World = Field(default_factory=World)
    _stored: Any = PrivateAttr(None)  # the uploaded robot (app/robots/legmap.py Robot), None for a built-in

    @field_validator("robot")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in KIND.robots and not re.fullmatch(ROBOT_ID, v):
            raise ValueError(f"unknown robot {v!r}; a simulated reality is one of {sorted(KIND.robots)} or the id "
                             "of an uploaded robot (32 hex digits)")
        return v

    @property
    def stored(self) -> Any:
        return self._stored

    @classmethod
    def parse(cls, data: Any, robots: Callable[[str], Any] | None = None) -> Reality:
        """Validate ``data`` (decoded JSON); SpecError naming every bad field. The damage is
        checked against the robot by the repertoire kind's spec (its messages name the field);
        an uploaded robot is read with ``robots(id)`` (SpecError when there is none) and the
        damage checked against its leg map."""
        if not isinstance(data, dict):
            raise SpecError([{"field": "reality", "message": "a reality must be a JSON object"}])
        try:
            r = cls.model_validate_json(json.dumps(data, allow_nan=True))
        except ValidationError as e:
            raise SpecError.from_validation(e, cls) from None
        spec = KIND.Spec.parse({"kind": KIND.name, "robot": r.robot, "damage": data.get("damage", {})})
        if r.robot not in KIND.robots:
            if robots is None:
                raise SpecError([{"field": "robot", "message": f"{r.robot!r} is an uploaded robot's id, and no "
                                                               "robots are available here to read it from"}])
            r._stored = robots(r.robot)
            problem = KIND.user_robot_error(spec, r._stored.legs.to_json())
            if problem:
                raise SpecError([{"field": "damage", "message": problem}])
        return r


@dataclasses.dataclass(frozen=True)
class Measured:
    """What a lab measures of one trial: the robot's displacement in its start frame."""

    forward_m: float
    lateral_m: float
    yaw_deg: float
    fell: bool
    duration_s: float

    @property
    def yaw_rad(self) -> float:
        return math.radians(self.yaw_deg)

    @property
    def speed_m_s(self) -> float:
        """The trial's figure against the evaluation's oracle: its forward speed, 0 when it fell."""
        return 0.0 if self.fell else self.forward_m / self.duration_s


def _spec(reality: Reality, rep: Repertoire):
    return KIND.Spec.parse({"kind": KIND.name, "robot": reality.robot, "damage": reality.damage.model_dump(),
                            "controller": rep.controller, "sim": rep.sim})


def play_many(reality: Reality, rep: Repertoire, elites) -> list[Measured]:
    """Elites ``elites`` of map ``rep`` played on the reality in one batched call of the
    repertoire's evaluator (each rollout independent of the others in the batch: a gait
    measures the same alone or among others, tests/adapt/test_reality.py)."""
    idx = [int(i) for i in elites]
    if not idx:
        return []
    m = KIND.play(_spec(reality, rep), rep.params[idx], rep.joints, reality.perturbation.perturbation(),
                  reality.stored)
    return [Measured(float(m["forward_m"][k]), float(m["lateral_m"][k]), float(m["yaw_deg"][k]), bool(m["fell"][k]),
                     float(m["duration_s"][k])) for k in range(len(idx))]


def play(reality: Reality, rep: Repertoire, elite: int) -> Measured:
    """Elite ``elite`` of map ``rep`` played on the reality (module doc)."""
    return play_many(reality, rep, [elite])[0]


# -- priors from re-simulation (gaitmend's scenario priors) -----------------------------------------

def pooled(reps: list[Repertoire], name: str = "pooled") -> Repertoire:
    """The elites of maps of one behaviour space and one set of joints (app/adapt/maps.py
    ``in_space_of``), end to end in the maps' order, as one map."""
    first = reps[0]
    m = Map(name, np.concatenate([r.map.descriptors for r in reps]), np.concatenate([r.map.forward_m for r in reps]),
            np.concatenate([r.map.lateral_m for r in reps]), first.map.trial_s)
    return dataclasses.replace(first, map=m, params=np.concatenate([r.params for r in reps]),
                               cells=[c for r in reps for c in r.cells])


def rescore(pool: Repertoire, scenarios: dict[str, Reality]) -> dict[str, list[Measured]]:
    """Every elite of ``pool`` played on each scenario (a stated damage, in the nominal or a
    training world): what a lab can simulate before the damage. One batched call each."""
    every = range(len(pool.map.forward_m))
    return {name: play_many(r, pool, every) for name, r in scenarios.items()}


def scenario_priors(pool: Repertoire, measured: dict[str, list[Measured]], mean: str) -> list[Repertoire]:
    """Priors over the same elites, one per scenario (its forward and lateral distance there,
    a fall counting 0 forward), and first their mean (named ``mean``): the performance a gait
    can expect of a damage among the scenarios. Given together to ``methods.GAITMEND`` (priors
    on), the trials pick the scenario that explains them best; the mean alone is one prior."""
    fwd = {k: np.array([0.0 if m.fell else m.forward_m for m in ms]) for k, ms in measured.items()}
    lat = {k: np.array([m.lateral_m for m in ms]) for k, ms in measured.items()}
    out = [(mean, np.mean(list(fwd.values()), axis=0), np.mean(list(lat.values()), axis=0))]
    out += [(f"on {k}", fwd[k], lat[k]) for k in measured]
    return [dataclasses.replace(pool, map=dataclasses.replace(pool.map, name=n, forward_m=f, lateral_m=l))
            for n, f, l in out]

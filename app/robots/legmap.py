"""A robot as data: an MJCF model, its asset files and a leg map.

The leg map says, for each leg, its name, side and front-to-back order, its joints from
the body out and its foot (a site, geom or body, with an optional offset in that
object's frame); the trunk body and which trunk axis points forward; optionally the
stance pose and servo gains. It is a strict model: every number and list is bounded,
unknown keys are refused, and it round-trips through JSON unchanged (docs/robots.md).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

# Leg names end up in job specs, file names and URLs: a short plain identifier.
LegName = Annotated[str, Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.\-]{0,63}$")]
# MJCF names as the model spells them: any printable text, bounded.
MjName = Annotated[str, Field(min_length=1, max_length=128, pattern=r"^[^\x00-\x1f\x7f]+$")]
Coord = Annotated[float, Field(ge=-10.0, le=10.0)]  # metres in an object's frame
JointValue = Annotated[float, Field(ge=-10.0, le=10.0)]  # rad (hinge) or m (slide)

MAX_LEGS = 16
MAX_JOINTS_PER_LEG = 8
FORWARD_AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0)}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)


class Foot(_Strict):
    """The point of a leg that touches the ground: an object of the model and an offset
    in its frame (a capsule's end cap, say)."""

    kind: Literal["site", "geom", "body"]
    name: MjName
    offset: list[Coord] = Field(default_factory=lambda: [0.0, 0.0, 0.0], min_length=3, max_length=3)


class Gains(_Strict):
    """Position-servo gains of a joint: N*m/rad (or N/m), N*m*s/rad, N*m/(rad*s); the
    torque (force) limit in N*m (N)."""

    kp: float = Field(gt=0.0, le=1e6)
    kd: float = Field(0.0, ge=0.0, le=1e5)
    ki: float = Field(0.0, ge=0.0, le=1e6)
    force_limit: float | None = Field(None, gt=0.0, le=1e5)


class Leg(_Strict):
    name: LegName
    side: Literal["left", "right"]
    order: int = Field(ge=0, le=MAX_LEGS - 1, description="front-to-back rank on its side, 0 at the front")
    joints: list[MjName] = Field(min_length=1, max_length=MAX_JOINTS_PER_LEG, description="from the body out")
    foot: Foot
    stance: list[JointValue] | None = Field(None, max_length=MAX_JOINTS_PER_LEG,
                                            description="joint values of the standing pose, one per joint")
    gains: Gains | None = None

    @model_validator(mode="after")
    def _consistent(self):
        if len(set(self.joints)) != len(self.joints):
            raise ValueError(f"leg {self.name!r} names a joint twice")
        if self.stance is not None and len(self.stance) != len(self.joints):
            raise ValueError(f"leg {self.name!r}: stance has {len(self.stance)} values for {len(self.joints)} joints")
        return self


class LegMap(_Strict):
    version: Literal[1] = 1
    trunk: MjName
    forward: Literal["+x", "-x", "+y", "-y"] = Field("+x", description="the trunk axis that points forward; z is up")
    legs: list[Leg] = Field(min_length=1, max_length=MAX_LEGS)
    stance_height: float | None = Field(None, gt=0.0, le=10.0, description="hips above the feet when standing, m")
    gains: Gains | None = Field(None, description="every leg joint's gains unless its leg gives its own")

    @model_validator(mode="after")
    def _consistent(self):
        names = [l.name for l in self.legs]
        if len(set(names)) != len(names):
            raise ValueError(f"leg names repeat: {sorted(n for n in set(names) if names.count(n) > 1)}")
        joints = [j for l in self.legs for j in l.joints]
        if len(set(joints)) != len(joints):
            raise ValueError(f"a joint belongs to two legs: {sorted(j for j in set(joints) if joints.count(j) > 1)}")
        slots = [(l.side, l.order) for l in self.legs]
        if len(set(slots)) != len(slots):
            raise ValueError("two legs share a side and an order")
        return self

    # -- reading --------------------------------------------------------------------------
    @classmethod
    def parse(cls, data: str | bytes | Mapping) -> LegMap:
        """From JSON text or a decoded JSON object; LegMapError names the first problems."""
        try:
            if isinstance(data, Mapping):
                data = json.dumps(data, allow_nan=False)
            return cls.model_validate_json(data)
        except (ValidationError, ValueError, TypeError) as e:
            raise LegMapError(explain(e)) from None

    def to_json(self) -> dict:
        return self.model_dump(mode="json")

    def leg(self, name: str) -> Leg:
        for l in self.legs:
            if l.name == name:
                return l
        raise KeyError(f"no leg {name!r}; legs: {[l.name for l in self.legs]}")

    def joint_names(self) -> list[str]:
        """Every leg joint, legs in map order, each leg's from the body out."""
        return [j for l in self.legs for j in l.joints]

    def gains_of(self, leg: Leg) -> Gains | None:
        return leg.gains or self.gains

    def forward_vector(self) -> tuple[float, float, float]:
        return FORWARD_AXES[self.forward]

    def left_vector(self) -> tuple[float, float, float]:
        """z x forward: the trunk axis pointing to the robot's left."""
        fx, fy, _ = FORWARD_AXES[self.forward]
        return (-fy, fx, 0.0)


class LegMapError(ValueError):
    """A leg map that is malformed or does not fit its model; the message says what."""


def explain(e: Exception) -> str:
    if isinstance(e, ValidationError):
        parts = []
        for err in e.errors()[:5]:
            where = ".".join(str(p) for p in err["loc"]) or "leg map"
            parts.append(f"{where}: {err['msg'].removeprefix('Value error, ')}")
        return "; ".join(parts)
    return str(e)


def content_hash(mjcf: str, assets: Mapping[str, bytes], legs: LegMap) -> str:
    """sha256 over the model text, every asset (name and bytes) and the leg map: two robots
    with the same hash are the same robot; any change makes a new one."""
    h = hashlib.sha256()
    h.update(b"gaitmend-robot-v1\0")
    h.update(hashlib.sha256(mjcf.encode()).digest())
    for name in sorted(assets):
        h.update(name.encode() + b"\0" + hashlib.sha256(assets[name]).digest())
    h.update(json.dumps(legs.to_json(), sort_keys=True, separators=(",", ":")).encode())
    return h.hexdigest()


@dataclasses.dataclass(frozen=True)
class Robot:
    """An MJCF model (text), its assets by relative name, and its leg map."""

    name: str
    mjcf: str
    assets: Mapping[str, bytes]
    legs: LegMap

    def spec(self):
        import mujoco

        return mujoco.MjSpec.from_string(self.mjcf, assets=dict(self.assets))

    def model(self):
        return self.spec().compile()

    def content_hash(self) -> str:
        return content_hash(self.mjcf, self.assets, self.legs)

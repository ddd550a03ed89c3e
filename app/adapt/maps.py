"""A repertoire's result read as a prior for the adaptation: its elites as a ``methods.Map``
(descriptors scaled to [0, 1] by the descriptor's bounds, each elite's forward and lateral
distance over the map's trial) and what is needed to play any elite again: its controller
parameters, the servos they drive, the controller's settings and the trial's length.

Input: a repertoire bundle (the zip, its unpacked folder, or its manifest.json beside its
result.json) or a result JSON alone (result.json, or the last line of ``gaitmend run
--json``): the summary holds the elites (``elites``), the descriptor's bounds, the
controller's layout and the trial, so no other file is read. The format is the repertoire
kind's (docs/repertoire.md, app/jobs/repertoire/run.py ``_finish``)."""

from __future__ import annotations

import dataclasses
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import orjson

from app.adapt.methods import Map
from app.robots.damage import Damage


class MapError(ValueError):
    """A file that is not a readable repertoire result (the message says why)."""


@dataclasses.dataclass(frozen=True)
class Repertoire:
    map: Map
    params: np.ndarray  # (N, dim): each elite's gait in the controller's unit cube
    cells: list[int]  # each elite's cell of the archive
    joints: list[str]  # the servos the parameters drive, in order
    descriptor: list[str]  # the descriptor's dimensions by name (contact_leg1 ..., or forward_m, lateral_m)
    controller: dict  # the repertoire spec's controller section (amplitude, offset, period_s, ramp_s)
    sim: dict  # the repertoire spec's sim section (duration_s, settle_s, timestep_s)
    robot: str  # the robot the map was built on (summary robot.name)
    damage: dict  # the damage the map was built for
    source: str


def _loads(raw: bytes | str) -> Any:
    """JSON decoded by orjson (a 10,000-elite result is about 15 MB: 0.13 s against the standard
    library's 0.76 s, the same values), or by the standard library where orjson refuses what
    Python's json writes (NaN, Infinity)."""
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError:
        return json.loads(raw)


def _read(path: Path) -> dict:
    """The summary of a bundle zip, bundle folder, manifest.json or result JSON."""
    try:
        if path.suffix == ".zip":
            with zipfile.ZipFile(path) as z:
                return _loads(z.read("result.json"))
        if path.is_dir():
            return _loads((path / "result.json").read_bytes())
        data = _loads(path.read_bytes())
        if isinstance(data, dict) and "bundle_schema" in data:  # a manifest: its result beside it
            return _loads((path.parent / "result.json").read_bytes())
        return data
    except FileNotFoundError as e:
        raise MapError(f"{path}: not found ({Path(e.filename).name if e.filename else 'file'})") from None
    except (OSError, KeyError, UnicodeDecodeError, json.JSONDecodeError, zipfile.BadZipFile) as e:
        raise MapError(f"{path}: cannot read a repertoire result: {e}") from None


def damage_name(damage: dict) -> str:
    """A map's name from its damage: "intact", "lost leg1, leg6; locked leg2.leg2_femur" (the
    names the committed evaluations record), any other type in the robot layer's words
    (app/robots/damage.py ``Damage.WORDS``: "weak leg3_coxa at 20 % force"), so that no
    damaged map is called intact."""
    parts = []
    if damage.get("lost_legs"):
        parts.append("lost " + ", ".join(damage["lost_legs"]))
    if damage.get("locked_joints"):
        parts.append("locked " + ", ".join(f"{j['leg']}.{j['joint']}" for j in damage["locked_joints"]))
    d = Damage.model_validate({k: v for k, v in damage.items() if k in Damage.model_fields})
    parts += [Damage.WORDS[f](x) for f in Damage.model_fields if f not in ("lost_legs", "locked_joints")
              for x in getattr(d, f)]
    return "; ".join(parts) or "intact"


def read_repertoire(path: Path | str, name: str | None = None) -> Repertoire:
    path = Path(path)
    s = _read(path)
    need = ("elites", "descriptor", "controller", "trial", "robot")
    if not isinstance(s, dict) or any(k not in s for k in need):
        raise MapError(f"{path}: not a repertoire result (a summary with {', '.join(need)})")
    e, d = s["elites"], s["descriptor"]
    if not e.get("cell"):
        raise MapError(f"{path}: the map holds no elite")
    lo, hi = np.asarray(d["bounds"], dtype=float).T
    desc = (np.asarray(e["measures"], dtype=float) - lo) / (hi - lo)
    trial = s["trial"]
    c = s["controller"]
    m = Map(name or damage_name(s.get("damage") or {}), np.clip(desc, 0.0, 1.0),
            np.asarray(e["objective"], dtype=float), np.asarray(e["lateral_m"], dtype=float),
            float(trial["duration_s"]))
    return Repertoire(
        map=m, params=np.asarray(e["solution"], dtype=float), cells=[int(v) for v in e["cell"]],
        joints=list(c["joints"]), descriptor=list(d["names"]),
        controller={"amplitude": c["amplitude"], "offset": c["offset"], "period_s": list(c["period_s"]),
                    "ramp_s": c["ramp_s"]},
        sim={"duration_s": trial["duration_s"], "settle_s": trial["settle_s"], "timestep_s": trial["timestep_s"]},
        robot=str(s["robot"].get("name")), damage=s.get("damage") or {}, source=str(path))


def read_repertoires(paths: list[Path | str]) -> list[Repertoire]:
    """Several maps over one behaviour space (the same descriptor dimensions), each named by
    its damage; a name already taken gets " (2)", " (3)" ..."""
    out: list[Repertoire] = []
    for p in paths:
        r = read_repertoire(p)
        if out and r.descriptor != out[0].descriptor:
            raise MapError(f"{p}: its descriptor {r.descriptor} is not the first map's {out[0].descriptor}: maps "
                           "used together share one behaviour space (e.g. the displacement descriptor)")
        base, k = r.map.name, 1
        while any(o.map.name == r.map.name for o in out):
            k += 1
            r = dataclasses.replace(r, map=dataclasses.replace(r.map, name=f"{base} ({k})"))
        out.append(r)
    return out


HOLD = (0.0, 0.0, 0.5)  # a joint's (amplitude, phase, offset) in the unit cube that holds its stance


def in_space_of(rep: Repertoire, like: Repertoire) -> Repertoire:
    """Map ``rep`` (built for a damage that removed legs or servos) in the behaviour space and
    on the joints of map ``like`` (e.g. the intact robot's), so that maps of different damages
    serve together as priors and any of their gaits can be played on any robot of the kind:

    - descriptor: a contact-share dimension ``rep`` lacks (a lost leg) is 0, the share of the
      trial that leg's foot touches the floor (ITE's robot measures a lost leg so); the
      displacement descriptor is the same for every damage;
    - gait: a joint ``rep``'s gaits do not drive holds its stance (amplitude 0, offset at
      the stance: ``HOLD`` in the controller's unit cube), the period stays the gait's.

    Both maps must be of one robot and controller, ``rep``'s dimensions and joints among
    ``like``'s."""
    if rep.descriptor == like.descriptor and rep.joints == like.joints:
        return rep
    if rep.robot != like.robot or rep.controller != like.controller:
        raise MapError(f"{rep.source}: another robot or controller than {like.source}'s")
    if not set(rep.descriptor) <= set(like.descriptor) or not set(rep.joints) <= set(like.joints):
        raise MapError(f"{rep.source}: its descriptor {rep.descriptor} or joints are not within {like.source}'s")
    n = len(rep.map.forward_m)
    desc = np.zeros((n, len(like.descriptor)))
    for k, name in enumerate(rep.descriptor):
        desc[:, like.descriptor.index(name)] = rep.map.descriptors[:, k]
    params = np.tile(np.array([*HOLD * len(like.joints), 0.0]), (n, 1))
    for k, j in enumerate(rep.joints):
        i = like.joints.index(j)
        params[:, 3 * i:3 * i + 3] = rep.params[:, 3 * k:3 * k + 3]
    params[:, -1] = rep.params[:, -1]
    return dataclasses.replace(rep, map=dataclasses.replace(rep.map, descriptors=desc), params=params,
                               joints=list(like.joints), descriptor=list(like.descriptor))

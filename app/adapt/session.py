"""An adaptation session (issue 44): the trial loop of app/adapt/simulate.py served one
trial at a time, for a lab that runs each proposed gait on the robot and posts what it
measured. The session is created over one or more finished repertoire jobs (the maps, the
first one ITE's), with the trial length the lab runs and a stop rule; after each posted
trial the next proposal, the prediction behind it and the stop decision are computed
again from the maps and the trials so far (``methods.propose`` / ``methods.decide``: pure
functions), so the stored trials are the whole state and the same trials give the same
proposal after any restart, on any machine.

Nothing here touches the store: app/store/repo/adaptations.py keeps the rows and calls
``step`` inside the transaction that writes a trial."""

from __future__ import annotations

import dataclasses
import importlib.util
import io
import json
import math
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, ValidationError, field_validator

from app.adapt import methods as M
from app.adapt.lab import BOUNDS
from app.adapt.maps import Repertoire, read_repertoires
from app.jobs.base import SpecError, StrictModel

METHODS = {"ite": M.ITE, "gaitmend": M.GAITMEND}
MAX_TRIALS = 100  # a stop rule's cap; ITE's is 20
MAX_MAPS = 8
JOB_ID = r"^[0-9a-f]{32}$"


def _integral(v: Any) -> Any:
    """86.0 is an integer in JSON (and JSON Schema): taken as 86; 86.5 or "86" stay refused."""
    return int(v) if isinstance(v, float) and math.isfinite(v) and v.is_integer() and abs(v) < 2**53 else v


class Stop(StrictModel):
    """ITE's stop rule: stop when the best measured performance reaches ``alpha`` x the best
    predicted over the map, or after ``max_trials`` trials."""

    alpha: float = Field(0.9, ge=0.05, le=1.0, description=(
        "stop at alpha x the best predicted performance (ITE: 0.9; below 0.05 the rule stops at almost any walk)"))
    max_trials: int = Field(20, ge=1, le=MAX_TRIALS, description="stop after this many trials")

    _whole = field_validator("max_trials", mode="before")(_integral)


class SessionSpec(StrictModel):
    """What POST /api/adaptations takes."""

    repertoires: list[Annotated[str, Field(pattern=JOB_ID, description="a job id (32 hex digits)")]] = Field(
        ..., min_length=1, max_length=MAX_MAPS, json_schema_extra={"uniqueItems": True},
        description="ids of your finished repertoire jobs, the maps; the first is ITE's map")
    method: Literal["ite", "gaitmend"] = Field("ite", description=(
        "ite: Cully et al. 2015 as published (one map); gaitmend: several maps weighed by likelihood, straight "
        "walking, a fall counts 0"))
    trial_s: float | None = Field(None, ge=0.5, le=600.0, description=(
        "how long the lab runs each gait (s); default: the first map's trial length"))
    stop: Stop = Field(default_factory=Stop)
    name: str = Field("", max_length=200, description="a name for the session")

    @field_validator("repertoires")
    @classmethod
    def _once(cls, v: list[str]) -> list[str]:
        if len(set(v)) != len(v):
            raise ValueError("a repertoire is named twice")
        return v

    @classmethod
    def parse(cls, data: Any) -> SessionSpec:
        return _parse(cls, data, "session")


class TrialIn(StrictModel):
    """One measured trial, as the lab posts it. ``trial`` is the trial's number (1-based):
    posting trial n needs trials 1..n-1 stored; a number already stored is a repeat."""

    trial: int = Field(..., ge=1, le=MAX_TRIALS, description="this trial's number, 1 for the first")
    forward_m: float = Field(..., ge=BOUNDS["forward_m"][0], le=BOUNDS["forward_m"][1],
                             description="displacement forward in the robot's start frame (m)")
    lateral_m: float = Field(..., ge=BOUNDS["lateral_m"][0], le=BOUNDS["lateral_m"][1],
                             description="displacement to the left (m)")
    yaw_deg: float = Field(..., ge=BOUNDS["yaw_deg"][0], le=BOUNDS["yaw_deg"][1],
                           description="change of heading, counter-clockwise (deg)")
    fell: bool = Field(..., description="whether the robot fell")
    duration_s: float = Field(..., gt=0.0, le=BOUNDS["duration_s"][1], description="how long the gait ran (s)")
    note: str = Field("", max_length=500, description="anything the lab wants kept with the trial")

    _whole = field_validator("trial", mode="before")(_integral)

    @classmethod
    def parse(cls, data: Any) -> TrialIn:
        return _parse(cls, data, "trial")


def _parse(model, data: Any, what: str):
    if not isinstance(data, dict):
        raise SpecError([{"field": "body", "message": f"a {what} must be a JSON object"}])
    try:
        return model.model_validate(data)
    except ValidationError as e:
        raise SpecError.from_validation(e, model) from None


def settings_of(spec: SessionSpec) -> M.Settings:
    return dataclasses.replace(METHODS[spec.method], alpha=spec.stop.alpha, max_trials=spec.stop.max_trials)


# -- the maps ---------------------------------------------------------------------------------

class MapSource:
    """A finished repertoire job as a map's source: its id, a stamp that changes if its
    result could (its finish time) and its summary (result.json): a dict, its JSON text, or
    a function that reads either (read only when the map is not already held: a
    10,000-elite result is megabytes of JSON, best handed on as the text it is stored as)."""

    def __init__(self, job_id: str, stamp: str, summary: dict | str | Callable[[], dict | str]):
        self.job_id, self.stamp, self._summary = job_id, stamp, summary

    def _read(self) -> dict | str:
        if callable(self._summary):
            self._summary = self._summary()
        return self._summary

    @property
    def summary(self) -> dict:
        if isinstance(self._read(), str):
            self._summary = json.loads(self._summary)
        return self._summary

    def text(self) -> str:
        v = self._read()
        return v if isinstance(v, str) else json.dumps(v)


_CACHE: OrderedDict[tuple, list[Repertoire]] = OrderedDict()
_CACHE_LOCK = threading.Lock()
CACHE_SIZE = 8


def load_maps(sources: Sequence[MapSource]) -> list[Repertoire]:
    """The jobs' results read as maps (app/adapt/maps.py, named by damage, each with its
    job id as ``source``), kept in this process for the next trial: a finished job's result
    does not change, and a restart only costs one read."""
    key = tuple((s.job_id, s.stamp) for s in sources)
    with _CACHE_LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    with tempfile.TemporaryDirectory(prefix="gaitmend-maps-") as tmp:
        paths = []
        for k, s in enumerate(sources):  # maps.py reads a result JSON: the summary is exactly that
            p = Path(tmp) / f"{k}.json"
            p.write_text(s.text())
            paths.append(p)
        reps = [dataclasses.replace(r, source=s.job_id) for r, s in zip(read_repertoires(paths), sources)]
    with _CACHE_LOCK:
        _CACHE[key] = reps
        while len(_CACHE) > CACHE_SIZE:
            _CACHE.popitem(last=False)
    return reps


# -- a step of the loop -----------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class StoredTrial:
    """A trial as its row holds it."""

    index: int
    map: str
    elite: int
    forward_m: float
    lateral_m: float
    yaw_deg: float
    fell: bool
    duration_s: float

    def trial(self) -> M.Trial:
        return M.Trial(self.map, self.elite, self.forward_m, self.lateral_m, math.radians(self.yaw_deg), self.fell,
                       self.duration_s)


@dataclasses.dataclass(frozen=True)
class Step:
    """After the trials so far: the stop decision and, unless it stops, the next gait."""

    decision: M.Decision
    proposal: M.Proposal | None


def step(reps: Sequence[Repertoire], spec: SessionSpec, trials: Sequence[StoredTrial]) -> Step:
    s = settings_of(spec)
    maps = [r.map for r in reps]
    ts = [t.trial() for t in trials]
    d = M.decide(maps, ts, s)
    return Step(d, None if d.stop else M.propose(maps, ts, s))


def trial_s(reps: Sequence[Repertoire], spec: SessionSpec) -> float:
    return float(spec.trial_s if spec.trial_s is not None else reps[0].map.trial_s)


def proposal_json(reps: Sequence[Repertoire], spec: SessionSpec, p: M.Proposal, index: int) -> dict:
    """The gait to run as trial ``index``: which elite of which map (and its job), its
    parameters and descriptor, the prediction behind it (m/s of the method's performance)."""
    rep = next(r for r in reps if r.map.name == p.map)
    e = p.elite
    return {"trial": index, "map": p.map, "job": rep.source, "elite": e, "cell": int(rep.cells[e]),
            "params": [float(v) for v in rep.params[e]], "descriptor": [float(v) for v in rep.map.descriptors[e]],
            "descriptor_names": list(rep.descriptor), "predicted_m_s": p.predicted, "std": p.std,
            "acquisition": p.acquisition, "prior_m_s": p.prior, "trial_s": trial_s(reps, spec),
            "predicted_forward_m": p.predicted * trial_s(reps, spec),
            "log_likelihood": {k: float(v) for k, v in p.log_likelihood.items()},
            "map_best": bool(e == int(np.argmax(rep.map.forward_m)))}  # the job's replay shows this gait


def decision_json(d: M.Decision) -> dict:
    return {"stop": d.stop, "reason": d.reason, "best_trial": None if d.best_trial is None else d.best_trial + 1,
            "best_measured_m_s": d.best_measured, "max_predicted_m_s": d.max_predicted}


def target_m_s(reps: Sequence[Repertoire], stored: Any = None) -> float | None:
    """The recovery target of the maps' robot (app/adapt/recovered.py): a built-in robot's, or
    that of the uploaded robot ``stored`` (its model measured); None where it has none (an
    uploaded robot whose model is not at hand)."""
    from app.adapt.recovered import target_speed

    try:
        return float(target_speed(reps[0].robot, stored))
    except (KeyError, AttributeError, ValueError):
        return None


# -- a proposal taken to the robot ------------------------------------------------------------

SETPOINT_HZ = 100.0
README = """# gaitmend adaptation: trial {trial} of session {session}

The gait to run next: elite {elite} (cell {cell}) of the map "{map}" (repertoire job {job}),
predicted {pred:.4f} m/s forward. Run it for {trial_s:g} s, measure the robot's displacement
(forward and lateral, m), heading change (deg), whether it fell and how long it ran, and
post them as trial {trial}.

- gait.json: the proposal (the gait's parameters x in the controller's unit cube, its cell,
  descriptor and the prediction behind it)
- setpoints.csv: every joint's set-point (rad) at {hz:g} Hz over the trial, computed by the
  module below (t < 0 is not included: start from the stance)
- controller/repertoire_controller.py and controller/layout.json: the controller the map's
  simulation ran, numpy only: Layout.from_json(layout).setpoints_single(x, t)
- archive.csv: the gait's row of the map
"""


def _controller_module(text: str):
    """The shipped controller module, loaded from its text: the set-points a robot gets
    come from the very file it is handed."""
    spec = importlib.util.spec_from_loader("repertoire_controller", loader=None)
    mod = importlib.util.module_from_spec(spec)
    exec(compile(text, "controller/repertoire_controller.py", "exec"), mod.__dict__)  # our own file, shipped as is
    return mod


def proposal_files(summary: dict, proposal: dict, session_id: str) -> dict[str, bytes]:
    """The proposal as files for the robot: the repertoire kind's own export (its controller
    module and layout, through the kind contract's ``bundle_files``) of a map holding only
    the proposed elite, the gait, and its set-points over the trial."""
    from app.jobs.base import JobResult
    from app.jobs.registry import get_kind

    e, i = summary["elites"], proposal["elite"]
    one = dict(summary, elites={k: [v[i]] for k, v in e.items()}, best=None)
    result = JobResult(summary=one, history=[], traces={}, model_xml="", evaluations=0, sim_steps=0)
    files = {k: (v.encode() if isinstance(v, str) else v)
             for k, v in get_kind("repertoire").bundle_files(None, result).items()}
    mod = _controller_module(files["controller/repertoire_controller.py"].decode())
    layout = mod.Layout.from_json(json.loads(files["controller/layout.json"]))
    t = np.arange(0.0, proposal["trial_s"] + 1e-9, 1.0 / SETPOINT_HZ)
    q = layout.setpoints(np.asarray([proposal["params"]]), t)[0]
    buf = io.StringIO()
    buf.write(",".join(["t_s", *layout.joints]) + "\n")
    for k in range(len(t)):
        buf.write(",".join([f"{t[k]:.4f}", *(repr(float(v)) for v in q[k])]) + "\n")
    files["setpoints.csv"] = buf.getvalue().encode()
    files["gait.json"] = json.dumps(proposal, indent=2).encode()
    files["README.md"] = README.format(trial=proposal["trial"], session=session_id, elite=i, cell=proposal["cell"],
                                       map=proposal["map"], job=proposal["job"], pred=proposal["predicted_m_s"],
                                       trial_s=proposal["trial_s"], hz=SETPOINT_HZ).encode()
    return files

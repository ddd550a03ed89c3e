"""The study spec and its expansion into points. Every point is validated by its kind's own
Spec before anything is queued; one bad point rejects the study, naming the point and field."""

from __future__ import annotations

import copy
import itertools
import math
import os
from dataclasses import dataclass, field
from typing import Any

from pydantic import Field, ValidationError, field_validator, model_validator

from app.jobs.base import SpecError, StrictModel
from app.jobs.registry import parse_spec

PATH_RE = r"^[a-z_][a-z0-9_]*(\.[a-z_][a-z0-9_]*)*$"

# Upper bounds of one study; deployments lower or raise them by environment.
MAX_POINTS = int(os.environ.get("GAITMEND_MAX_STUDY_POINTS", "1000"))
MAX_STUDY_EVALUATIONS = int(os.environ.get("GAITMEND_MAX_STUDY_EVALUATIONS", "20000000"))


# A report that names no metrics reports the kind's headline: the row its jobs list shows
# (``Kind.list_headline``), read from each point's summary through ``get_path``.
HEADLINE = "headline"
DEFAULT_METRICS = [f"{HEADLINE}.primary"]


class Report(StrictModel):
    group_by: list[str] = Field(default_factory=list, max_length=8)
    metrics: list[str] = Field(default_factory=lambda: list(DEFAULT_METRICS), min_length=1, max_length=32)

    @field_validator("group_by", "metrics")
    @classmethod
    def _paths(cls, v: list[str]) -> list[str]:
        import re

        for p in v:
            if not re.fullmatch(PATH_RE, p) or len(p) > 200:
                raise ValueError(f"{p!r} is not a dotted path like 'best.metrics.y_f_m'")
        if len(set(v)) != len(v):
            raise ValueError("paths must be distinct")
        return v


class StudySpec(StrictModel):
    """``points`` (a list of override objects) or ``grid`` (path -> list of values, every
    combination); overrides are dotted paths into the base spec, e.g. ``search.seed``."""

    name: str = Field(min_length=1, max_length=200)
    base: dict[str, Any]
    points: list[dict[str, Any]] | None = Field(None, min_length=1, max_length=100_000)
    grid: dict[str, list[Any] | str] | None = Field(None, min_length=1, max_length=8)
    list_infeasible: bool = False  # infeasible damages are listed (never queued) instead of rejected
    report: Report = Field(default_factory=Report)

    @model_validator(mode="after")
    def _one_of(self):
        if (self.points is None) == (self.grid is None):
            raise ValueError("give exactly one of 'points' or 'grid'")
        return self


@dataclass
class Plan:
    study: StudySpec
    points: list[dict[str, Any]] = field(default_factory=list)  # {"index", "overrides", "spec", "budget"}
    infeasible: list[dict[str, Any]] = field(default_factory=list)  # {"overrides", "reason"}

    @property
    def evaluations(self) -> int:
        return sum(p["budget"] for p in self.points)


def set_path(d: dict, path: str, value: Any) -> None:
    keys = path.split(".")
    for k in keys[:-1]:
        nxt = d.get(k)
        if nxt is None:
            nxt = d[k] = {}
        if not isinstance(nxt, dict):
            raise KeyError(f"{k!r} is not an object")
        d = nxt
    d[keys[-1]] = copy.deepcopy(value)


def slug(label: str) -> str:
    """A headline row's label as a path segment: 'forward distance (cm)' -> 'forward_distance_cm'."""
    import re

    return re.sub(r"[^a-z0-9]+", "_", label.lower()).strip("_")


def headline_value(summary: dict, name: str) -> Any:
    """The value of a headline row of the summary's kind: ``primary`` (the row the jobs list
    shows) or a row's label as ``slug`` makes it."""
    from app.jobs.registry import KINDS

    kind = KINDS.get(summary.get("kind")) if isinstance(summary.get("kind"), str) else None
    if kind is None:
        return None
    try:
        row = kind.list_headline(summary) if name == "primary" else \
            next((r for r in kind.headline(summary) if slug(r["label"]) == name), None)
    except (KeyError, TypeError, ValueError):  # a summary of an older release
        return None
    return None if row is None else row.get("value")


def get_path(d: Any, path: str) -> Any:
    """The value at a dotted path ('best.metrics.y_f_m', 'damage.lost_legs.0'); in a job
    summary, ``headline.<name>`` reads the kind's headline (``headline_value``)."""
    if path.startswith(f"{HEADLINE}.") and isinstance(d, dict) and HEADLINE not in d and "kind" in d:
        return headline_value(d, path.split(".", 1)[1])
    for k in path.split("."):
        if isinstance(d, dict) and k in d:
            d = d[k]
        elif isinstance(d, list) and k.isdigit() and int(k) < len(d):
            d = d[int(k)]
        else:
            return None
    return d


def _kind_of(base: dict):
    from app.jobs.registry import get_kind

    try:
        return get_kind(base.get("kind"))
    except SpecError:
        return None  # the base's own validation names the bad kind


def infeasible_reason(spec: dict) -> str | None:
    """Why a point cannot run at all (the kind says: e.g. a hexapod without enough legs), else None."""
    kind = _kind_of(spec)
    return None if kind is None else kind.infeasible_reason(spec)


def _fail(field_: str, message: str) -> SpecError:
    return SpecError([{"field": field_, "message": message}])


def _override_list(study: StudySpec) -> list[dict[str, Any]]:
    import re

    if study.points is not None:
        for i, p in enumerate(study.points):
            for k in p:
                if not re.fullmatch(PATH_RE, k):
                    raise _fail(f"points[{i}].{k}", "override keys are dotted paths like 'search.seed'")
        return [dict(p) for p in study.points]
    axes = []
    for k, v in study.grid.items():
        if not re.fullmatch(PATH_RE, k):
            raise _fail(f"grid.{k}", "grid keys are dotted paths like 'search.seed'")
        if isinstance(v, str):
            kind = _kind_of(study.base)
            named = (kind.named_values() if kind is not None else {}).get(k, {})
            if v not in named:
                offered = {p: sorted(n) for p, n in (kind.named_values() if kind is not None else {}).items()}
                raise _fail(f"grid.{k}", f"a list of values, or a named set the base's kind offers: "
                                         f"{offered or 'none'}; got {v!r}")
            v = named[v]
        if not v:
            raise _fail(f"grid.{k}", "at least one value")
        axes.append([(k, x) for x in v])
    n = math.prod(len(a) for a in axes)
    if n > MAX_POINTS:
        raise _fail("grid", f"{n} points; the limit is {MAX_POINTS} per study (GAITMEND_MAX_STUDY_POINTS)")
    return [dict(c) for c in itertools.product(*axes)]


def parse_study(data: Any) -> StudySpec:
    if not isinstance(data, dict):
        raise _fail("study", "a study must be a JSON object")
    try:
        return StudySpec.model_validate(data)
    except ValidationError as e:
        raise SpecError.from_validation(e) from None


def expand(data: Any, max_points: int | None = None) -> Plan:
    """Parse the study and validate every point with its kind's Spec; SpecError on the first
    bad point (named ``points[i].<field>``) or on a limit."""
    study = parse_study(data) if not isinstance(data, StudySpec) else data
    limit = MAX_POINTS if max_points is None else max_points
    overrides = _override_list(study)
    if len(overrides) > limit:
        raise _fail("points", f"{len(overrides)} points; the limit is {limit} per study (GAITMEND_MAX_STUDY_POINTS)")
    plan = Plan(study)
    for i, ov in enumerate(overrides):
        d = copy.deepcopy(study.base)
        for k, v in ov.items():
            try:
                set_path(d, k, v)
            except KeyError as e:
                raise _fail(f"points[{i}].{k}", f"cannot set: {e.args[0]}") from None
        if (why := infeasible_reason(d)) is not None:
            if not study.list_infeasible:
                raise _fail(f"points[{i}].damage.lost_legs", f"infeasible damage {ov}: {why} "
                                                             "(set list_infeasible to list such points instead)")
            damage = {k: v for k, v in ov.items() if k.startswith("damage.")} or ov
            if not any(x["overrides"] == damage for x in plan.infeasible):  # once per damage, not per seed
                plan.infeasible.append({"overrides": damage, "reason": why})
            continue
        try:
            spec = parse_spec(d)
        except SpecError as e:
            first = e.errors[0] if e.errors else {"field": "spec", "message": str(e)}
            raise SpecError([{"field": f"points[{i}].{x['field']}", "message": f"{x['message']} (overrides {ov})"}
                             for x in (e.errors or [first])]) from None
        plan.points.append({"index": len(plan.points), "overrides": ov, "spec": spec.model_dump(mode="json"),
                            "budget": int(spec.evaluations_budget), "kind": spec.kind,
                            "robot": getattr(spec, "robot", None)})
    if not plan.points:
        raise _fail("points", "no runnable point (every point is infeasible)")
    if plan.evaluations > MAX_STUDY_EVALUATIONS:
        raise _fail("points", f"the points need {plan.evaluations} evaluations in all; the limit is "
                              f"{MAX_STUDY_EVALUATIONS} per study (GAITMEND_MAX_STUDY_EVALUATIONS)")
    return plan


def axes_of(study: StudySpec) -> list[str]:
    """Every overridden path, in order of first appearance."""
    if study.grid is not None:
        return list(study.grid)
    seen: dict[str, None] = {}
    for p in study.points or []:
        seen.update(dict.fromkeys(p))
    return list(seen)

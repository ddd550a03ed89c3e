"""Response models, and the request body schema built from the job-kind registry."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, Field, TypeAdapter

from app.jobs.registry import KINDS
from app.store.models import Job

Status = Literal["queued", "running", "succeeded", "failed", "cancelled"]


def best_fitness(job) -> float | None:
    s = job.summary or {}
    for path in (("best", "fitness"), ("result", "best_fitness")):
        v: Any = s
        for k in path:
            v = v.get(k) if isinstance(v, dict) else None
        if isinstance(v, (int, float)):
            return float(v)
    info = job.progress_info or {}
    return float(info["best"]) if isinstance(info.get("best"), (int, float)) else None


def damage_text(spec: dict | None) -> str:
    d = (spec or {}).get("damage") or {}
    parts = []
    if d.get("lost_legs"):
        parts.append("lost " + ",".join(str(x) for x in d["lost_legs"]))
    for key, word in (("locked_joints", "locked"), ("weak_joints", "weak")):
        for j in d.get(key) or []:
            if isinstance(j, dict):
                parts.append(f"{word} {j.get('leg')}.{j.get('joint')}")
    for key, v in d.items():  # other kinds' damage, e.g. stuck_modules
        if key not in ("lost_legs", "locked_joints", "weak_joints") and isinstance(v, list) and v:
            parts.append(f"{key.replace('_', ' ')} " + ",".join(str(x) for x in v))
    if not parts:
        sc = (spec or {}).get("scenario")
        if isinstance(sc, dict) and sc.get("type"):
            return str(sc["type"])
    return "; ".join(parts) or "none"


class FieldError(BaseModel):
    field: str
    message: str


class ErrorOut(BaseModel):
    detail: str
    errors: list[FieldError] = []


# The error statuses a job route can answer, each with the ErrorOut body (OpenAPI).
ERROR_RESPONSES: dict[int | str, dict] = {r: {"model": ErrorOut} for r in (401, 404, 409, 410, 413, 415, 422, 429)}
# A bundle member's name: segments of letters, digits, "_", "-" and ".", none starting with a dot.
MEMBER_PATTERN = r"^[A-Za-z0-9_-][A-Za-z0-9_.-]*(/[A-Za-z0-9_-][A-Za-z0-9_.-]*)*$"


class Progress(BaseModel):
    done: int
    total: int
    fraction: float
    info: dict[str, Any] | None = None


class JobOut(BaseModel):
    id: str
    kind: str
    robot: str | None
    status: Status
    owner: str
    attempt: int = Field(description="claims by a worker so far; each worker death costs one")
    max_attempts: int
    cancel_requested: bool
    progress: Progress
    created_at: dt.datetime
    started_at: dt.datetime | None
    finished_at: dt.datetime | None
    updated_at: dt.datetime
    wall_s: float | None = Field(None, description="started to finished (or now), seconds")
    error: str | None
    damage: str = Field(description="the spec's damage in words, e.g. 'lost 1,6; locked 2.femur'")
    best_fitness: float | None = Field(None, description="best objective so far (final once succeeded)")
    headline: list[dict[str, Any]] | None = Field(
        None, description="the kind's headline rows once the job succeeded: label, value, unit, better, target, met")
    summary: dict[str, Any] | None = None
    spec: dict[str, Any] | None = None
    links: dict[str, str]

    @classmethod
    def of(cls, job: Job, detail: bool = True) -> JobOut:
        end = job.finished_at or dt.datetime.now(dt.timezone.utc)
        base = f"/api/jobs/{job.id}"
        return cls(
            id=job.id, kind=job.kind, robot=job.robot, status=job.status, owner=job.owner, attempt=job.attempt,
            max_attempts=job.max_attempts, cancel_requested=job.cancel_requested,
            progress=Progress(done=job.progress_done, total=job.progress_total,
                              fraction=(job.progress_done / job.progress_total) if job.progress_total else
                              (1.0 if job.status == "succeeded" else 0.0),
                              info=job.progress_info),
            created_at=job.created_at, started_at=job.started_at, finished_at=job.finished_at,
            updated_at=job.updated_at,
            wall_s=(end - job.started_at).total_seconds() if job.started_at else None,
            error=job.error, damage=damage_text(job.spec), best_fitness=best_fitness(job), headline=_headline(job),
            summary=job.summary if detail else None, spec=job.spec if detail else None,
            links={"self": base, "history": f"{base}/history", "events": f"{base}/events",
                   "bundle": f"{base}/bundle"})


def _headline(job: Job) -> list[dict[str, Any]] | None:
    kind = KINDS.get(job.kind)
    if kind is None or job.status != "succeeded" or not job.summary:
        return None
    try:
        return [dict(r) for r in kind.headline(job.summary)]
    except (KeyError, TypeError, ValueError, IndexError):  # a summary from an older version of the kind
        return None


class JobList(BaseModel):
    items: list[JobOut]
    next_cursor: str | None = Field(None, description="pass as ?cursor= for the next (older) page")


class WorkerOut(BaseModel):
    name: str
    broker: str
    started_at: dt.datetime
    last_seen_at: dt.datetime


class Health(BaseModel):
    """With auth required, a caller without a valid token gets `status` only: worker
    hostnames, PIDs and the broker's address are for token holders."""

    status: Literal["ok", "degraded"]
    database: str | None = None
    broker: str | None = None
    broker_url: str | None = None
    workers: list[WorkerOut] | None = None


def spec_union():
    """The body of POST /jobs: a discriminated union on `kind` over every registered kind."""
    models = tuple(m.Spec for m in KINDS.values())
    if len(models) == 1:
        return models[0]
    return Annotated[Union[models], Field(discriminator="kind")]  # noqa: UP007


def spec_json_schema() -> tuple[dict, dict]:
    """(JobSpec schema, its definitions) with refs into #/components/schemas."""
    schema = TypeAdapter(spec_union()).json_schema(ref_template="#/components/schemas/{model}")
    defs = schema.pop("$defs", {})
    # `kind` has a default in each model (its own name) but a body must name it: say so.
    refs = list((schema.get("discriminator") or {}).get("mapping", {}).values())
    for branch in [defs[r.rsplit("/", 1)[1]] for r in refs if r.rsplit("/", 1)[1] in defs] or [schema]:
        if "kind" in branch.get("properties", {}):
            branch["required"] = ["kind", *[f for f in branch.get("required", []) if f != "kind"]]
    return schema, defs

"""Response models, and the request body schema built from the job-kind registry."""

from __future__ import annotations

import datetime as dt
from typing import Any, Literal

from pydantic import BaseModel, Field

from app.jobs.base import SpecError
from app.jobs.registry import KINDS
# The body of POST /api/jobs: a discriminated union on `kind`, every section named after its kind.
from app.jobs.schema import spec_json_schema, spec_union  # noqa: F401  (create_app and the tests use them here)
from app.store.models import Job

Status = Literal["queued", "running", "succeeded", "failed", "cancelled"]


def _kind(job):
    return KINDS.get(job.kind)  # a job of a kind no longer registered still lists


def damage_text(job) -> str:
    kind = _kind(job)
    if kind is None or not isinstance(job.spec, dict):
        return ""
    try:
        return kind.damage_text(kind.Spec.parse(job.spec))
    except (SpecError, KeyError, TypeError, ValueError, AttributeError):  # a spec stored by an older release
        return ""


def headline(job) -> list[HeadlineOut] | None:
    kind = _kind(job)
    if kind is None or not job.summary:
        return None
    try:
        return [HeadlineOut(**row) for row in kind.headline(job.summary)]
    except (KeyError, TypeError, ValueError):
        return None


def verdict(job) -> dict[str, Any] | None:
    """The kind's verdict in brief (app/jobs/verdict.py's ``brief``): target met, the
    controls, the held-out figure (kept, falls, fragile, in words) and the sentence."""
    kind = _kind(job)
    if kind is None or not job.summary or job.status != "succeeded":
        return None
    from app.jobs.verdict import brief

    try:
        return brief(kind.verdict(job.summary))
    except (KeyError, TypeError, ValueError):  # a summary stored by an older release
        return None


def progress_text(job) -> str | None:
    kind = _kind(job)
    if kind is None or not job.progress_info:
        return None
    try:
        return kind.progress_text(job.progress_info)
    except (KeyError, TypeError, ValueError):
        return None


class HeadlineOut(BaseModel):
    """One number a user came for (the kind's ``headline``)."""

    label: str
    value: Any = Field(description="a number, a flag, a text or a list (e.g. a foothold)")
    unit: str
    better: Literal["higher", "lower"] | None = Field(description="which direction is better, if any")
    target: str | None = Field(description="the target in words, if the kind states one")
    met: bool | None = Field(description="whether the value meets the target")


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
    text: str | None = Field(None, description="the kind's one-line progress text")


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
    damage: str = Field(description="the damage or scenario in words, as the kind words it, e.g. 'lost 1,6; "
                                    "locked 2.femur'")
    headline: list[HeadlineOut] | None = Field(None, description="the numbers a user came for, once succeeded")
    verdict: dict[str, Any] | None = Field(None, description=(
        "did the method work, in brief, once succeeded: target_met, controls (beat / tied / lost), held_out (the "
        "held-out random models: n, met, judged, fell, share, interval, fragile, text, headline; null without a "
        "held-out set), robustness [met, total] of the named cases and timestep checks, and the sentence"))
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
                              info=job.progress_info, text=progress_text(job)),
            created_at=job.created_at, started_at=job.started_at, finished_at=job.finished_at,
            updated_at=job.updated_at,
            wall_s=(end - job.started_at).total_seconds() if job.started_at else None,
            error=job.error, damage=damage_text(job), headline=headline(job), verdict=verdict(job),
            summary=job.summary if detail else None, spec=job.spec if detail else None,
            links={"self": base, "history": f"{base}/history", "events": f"{base}/events",
                   "bundle": f"{base}/bundle", "video": f"{base}/video", "thumbnail": f"{base}/thumbnail"})


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
    reasons: list[str] | None = Field(None, description="why the service is degraded (empty when ok)")
    database: str | None = None
    broker: str | None = None
    broker_url: str | None = None
    workers: list[WorkerOut] | None = None
    disk: dict | None = Field(None, description="the data folder: path, free_bytes, min_free_bytes, low")
    queue: dict | None = Field(None, description="running jobs, live worker slots, jobs waiting past "
                                                 "GAITMEND_STALL_AFTER_S")


class BuiltinStudyOut(BaseModel):
    name: str = Field(description="what GET /api/studies/builtin/{name} and `gaitmend study run NAME` take")
    kind: str = Field(description="the job kind of the study's base spec (the kind that ships it)")
    title: str = Field(description="the study spec's own name")


class BuiltinStudyList(BaseModel):
    """Every registered kind's built-in studies, in registry order, each kind's paper table first."""

    items: list[BuiltinStudyOut]


def adaptation_body_schema(name: str) -> dict:
    """The JSON schema of an adaptation request body (app/adapt/session.py ``SessionSpec``
    or ``TrialIn``) with its definitions inlined (an operation's body cannot carry $defs)."""
    import json

    from app.adapt import session

    sch = getattr(session, name).model_json_schema()
    defs = sch.pop("$defs", {})
    text = json.dumps(sch)
    for key, d in defs.items():
        text = text.replace(json.dumps({"$ref": f"#/$defs/{key}"}), json.dumps(d))
    return json.loads(text)

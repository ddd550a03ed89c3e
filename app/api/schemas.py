"""Response models, and the request body schema built from the job-kind registry."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, Field, TypeAdapter

from app.jobs.registry import KINDS
from app.store.models import Job

Status = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class FieldError(BaseModel):
    field: str
    message: str


class ErrorOut(BaseModel):
    detail: str
    errors: list[FieldError] = []


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
            error=job.error, summary=job.summary if detail else None, spec=job.spec if detail else None,
            links={"self": base, "history": f"{base}/history", "events": f"{base}/events",
                   "bundle": f"{base}/bundle"})


class JobList(BaseModel):
    items: list[JobOut]
    next_cursor: str | None = Field(None, description="pass as ?cursor= for the next (older) page")


class WorkerOut(BaseModel):
    name: str
    broker: str
    started_at: dt.datetime
    last_seen_at: dt.datetime


class Health(BaseModel):
    status: Literal["ok", "degraded"]
    database: str
    broker: str
    broker_url: str
    workers: list[WorkerOut]


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
    return schema, defs

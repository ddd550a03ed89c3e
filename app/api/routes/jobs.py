"""/api/jobs: validate, call one repository function, return a response model."""

from __future__ import annotations

import asyncio
import csv
import io
from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, Header, Path as PathParam, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse, StreamingResponse
from sqlalchemy.exc import IntegrityError

from app.api.auth import Principal, principal
from app.api.body import BodyError, parse_json
from app.api.deps import Db, get_db, settings_of
from app.api.errors import ApiError
from app.api.schemas import ERROR_RESPONSES, JobList, JobOut, Status
from app.service.dispatch import send
from app.jobs.base import SpecError
from app.jobs.registry import parse_spec
from app.core.settings import Settings
from app.store import repo, space
from app.store.errors import transient
from app.store.models import FINAL, utcnow

router = APIRouter(prefix="/jobs", tags=["jobs"])

JobId = Annotated[str, PathParam(min_length=1, max_length=64, description="job id")]
ERRORS = ERROR_RESPONSES


async def _read_body(request: Request, limit: int) -> bytes:
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise ApiError(413, f"request body larger than {limit} bytes (GAITMEND_MAX_BODY_BYTES)", field="body")
        chunks.append(chunk)
    return b"".join(chunks)


def _require_json(request: Request) -> None:
    """Bodies must say they are JSON (application/json or a +json type): a form post or a
    text/plain body from a browser or a careless script is refused, not guessed at."""
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype != "application/json" and not (ctype.startswith("application/") and ctype.endswith("+json")):
        raise ApiError(415, f"Content-Type must be application/json, got {ctype or 'none'!r}",
                       field="Content-Type")


def _budget_error(spec, limit: int) -> ApiError | None:
    budget = int(spec.evaluations_budget)
    if budget <= limit:
        return None
    return ApiError(422, f"the spec needs {budget} evaluations ({spec.budget_formula}); "
                         f"the limit is {limit} per job (GAITMEND_MAX_EVALUATIONS_PER_JOB)", field=spec.budget_field)


async def read_spec(request: Request, settings: Settings):
    """The job spec in a request's body, through every edge (JSON content type, size,
    strict JSON, the kind's Spec, the evaluation limit); an ApiError names what failed.
    Shared by POST /api/jobs and the dashboard's check, so what passes one passes the other."""
    _require_json(request)
    body = await _read_body(request, settings.max_body_bytes)
    try:
        data = parse_json(body)
    except BodyError as e:
        raise ApiError(422, f"the body is not an acceptable JSON document: {e}", errors=e.errors) from None
    try:
        spec = parse_spec(data)
    except SpecError as e:
        raise ApiError(422, str(e), errors=e.errors) from None
    if (err := _budget_error(spec, settings.max_evaluations_per_job)) is not None:
        raise err
    return spec


async def check_robot(spec, who: Principal, db: Db) -> None:
    """A spec naming an uploaded robot: it must be one of the caller's (422 naming `robot`,
    the same for another owner's robot as for a missing one) and the spec must fit its leg
    map (422 naming the damage)."""
    from app.jobs.registry import get_kind, robots as builtin_robots
    from app.store import robots as robot_store

    name = getattr(spec, "robot", None)
    if name is None or name in builtin_robots():
        return

    def legs(s):
        try:
            return robot_store.get_robot(s, name, who.owner_filter).legs
        except repo.NotFound:
            return None

    found = await db.read(legs)
    if found is None:
        raise ApiError(422, f"robot: no robot {name!r} of yours (GET /api/robots lists them)", field="robot")
    why = get_kind(spec.kind).user_robot_error(spec, found)
    if why is not None:
        raise ApiError(422, why, field=why.split(":", 1)[0])


async def accepted_spec(request: Request, settings: Settings, who: Principal, db: Db):
    """The spec POST /api/jobs would queue: every edge of ``read_spec`` and, for an uploaded
    robot, ``check_robot``. The dashboard's dry run asks the same, so neither can refuse
    what the other accepts."""
    spec = await read_spec(request, settings)
    await check_robot(spec, who, db)
    return spec


@router.post("", status_code=201, response_model=JobOut, responses=ERRORS | {200: {"model": JobOut,
             "description": "a retry with the same Idempotency-Key: the job created the first time"}},
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/json": {"schema": {"$ref": "#/components/schemas/JobSpec"}}}}})
async def submit(request: Request, response: Response, who: Principal = Depends(principal),
                 idempotency_key: Annotated[str | None, Header(min_length=1, max_length=200)] = None,
                 db: Db = Depends(get_db)):
    """Queue a job. The body is the job spec (the same as `gaitmend run`); every field is
    checked before anything is written."""
    settings = settings_of(request)
    spec = await accepted_spec(request, settings, who, db)
    full = spec.model_dump(mode="json")

    def existing():
        with db.session(readonly=True) as s:
            job = repo.find_by_idempotency_key(s, who.name, idempotency_key)
        if job.spec != full:
            raise repo.Conflict("Idempotency-Key was used before with a different spec", field="Idempotency-Key")
        return job, False

    def create_and_send():
        # One trip to the thread pool: commit the row, then send its id.
        try:
            with db.session() as s:
                job, created = repo.submit_job(
                    s, owner=who.name, kind=spec.kind, robot=getattr(spec, "robot", None), spec=full,
                    evaluations_budget=int(spec.evaluations_budget), max_attempts=settings.max_attempts,
                    max_queued=settings.max_queued_per_owner, idempotency_key=idempotency_key)
        except IntegrityError:  # only without the owner lock (never expected): the unique key held
            if not idempotency_key:
                raise
            return existing()
        if created:
            send(settings, [job.id])
        return job, created

    try:
        job, created = await run_in_threadpool(create_and_send)
    except repo.Conflict as e:
        raise ApiError(409, str(e), field=e.field) from None
    except repo.QueueFull as e:
        raise ApiError(429, f"{e.queued} jobs are already queued for {who.name!r}; the limit is {e.limit} "
                            f"(GAITMEND_MAX_QUEUED_PER_OWNER); wait or cancel some", field="owner") from None
    if not created:
        response.status_code = 200
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return JobOut.of(job)


@router.get("", response_model=JobList, responses=ERRORS)
async def list_jobs(who: Principal = Depends(principal), db: Db = Depends(get_db),
                    status: Status | None = None,
                    kind: Annotated[str | None, Query(max_length=32)] = None,
                    robot: Annotated[str | None, Query(max_length=64)] = None,
                    limit: Annotated[int, Query(ge=1, le=500)] = 50,
                    cursor: Annotated[str | None, Query(pattern=repo.CURSOR_PATTERN,
                                                       description="next_cursor of the previous page")] = None):
    """Jobs, newest first, filtered by status, kind and robot; keyset pagination."""
    before = None
    if cursor:
        try:
            before = repo.decode_cursor(cursor)
        except ValueError as e:
            raise ApiError(422, str(e), field="cursor") from None
    rows, nxt = await db.read(lambda s: repo.list_jobs(s, owner=who.owner_filter, status=status, kind=kind,
                                                        robot=robot, limit=limit, before_seq=before))
    return JobList(items=[JobOut.of(j, detail=False) for j in rows],
                   next_cursor=repo.encode_cursor(nxt) if nxt is not None else None)


@router.get("/{job_id}", response_model=JobOut, responses=ERRORS)
async def get_job(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    job = await db.read(lambda s: repo.get_job(s, job_id, who.owner_filter))
    return JobOut.of(job)


@router.get("/{job_id}/history", responses=ERRORS | {200: {"content": {"application/json": {}, "text/csv": {}},
                                                           "description": "one row per generation"}})
async def get_history(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db),
                      format: Literal["json", "csv"] = "json"):
    """Per-generation metrics: progress rows while running, the job's own history once done."""
    rows = await db.read(lambda s: repo.history(s, repo.get_job(s, job_id, who.owner_filter)))
    if format == "json":
        return rows
    buf = io.StringIO()
    fields = list(dict.fromkeys(k for r in rows for k in r))
    w = csv.DictWriter(buf, fieldnames=fields)
    w.writeheader()
    w.writerows(rows)
    return Response(buf.getvalue(), media_type="text/csv")


@router.get("/{job_id}/events", responses=ERRORS | {200: {"content": {"text/event-stream": {}},
                                                          "description": "progress events, then one final 'end'"}})
async def events(request: Request, job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """Server-sent events: `progress` whenever the job changes, then `end` with its final state."""
    first = await db.read(lambda s: repo.get_job(s, job_id, who.owner_filter))

    async def stream():
        job, last, idle = first, None, 0.0
        while True:
            out = JobOut.of(job, detail=job.status in FINAL)
            stamp = (job.status, job.updated_at, job.progress_done)
            if job.status in FINAL:
                yield f"event: end\ndata: {out.model_dump_json()}\n\n"
                return
            if stamp != last:
                yield f"event: progress\ndata: {out.model_dump_json()}\n\n"
                last, idle = stamp, 0.0
            elif idle >= 15:
                yield ": keep-alive\n\n"
                idle = 0.0
            if await request.is_disconnected():
                return
            await asyncio.sleep(0.5)
            idle += 0.5
            try:
                job = await db.read(lambda s: repo.get_job(s, job_id, who.owner_filter))
            except ApiError:  # deleted meanwhile
                yield "event: end\ndata: {\"status\": \"deleted\"}\n\n"
                return
            except Exception as e:  # the database away mid-stream: the answer has begun, keep polling
                if transient(e) is None:
                    raise

    return StreamingResponse(stream(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


@router.post("/{job_id}/cancel", response_model=JobOut, status_code=202, responses=ERRORS)
async def cancel(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """A queued job is cancelled at once and never starts; a running one stops within a generation."""
    return JobOut.of(await db.write(lambda s: repo.request_cancel(s, job_id, who.owner_filter)))


@router.post("/{job_id}/retry", response_model=JobOut, status_code=202, responses=ERRORS)
async def retry(request: Request, job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """Run a failed or cancelled job again; it resumes from its last checkpoint."""
    def do(s):
        job = repo.retry(s, job_id, who.owner_filter)
        job.dispatched_at = utcnow()
        return job

    job = await db.write(do)
    await run_in_threadpool(send, settings_of(request), [job.id])
    return JobOut.of(job)


@router.delete("/{job_id}", status_code=204, responses=ERRORS)
async def delete(request: Request, job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """Delete a job that is not running, with its history, checkpoint and bundle; it also
    works on a full disk, to free space (app/store/space.py delete_job)."""
    settings = settings_of(request)
    await db.call(lambda: space.delete_job(settings, job_id, who.owner_filter))
    return Response(status_code=204)


@router.get("/{job_id}/bundle", responses=ERRORS | {200: {"content": {"application/zip": {}},
                                                          "description": "the result bundle"}})
async def bundle(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    job = await db.read(lambda s: repo.get_job(s, job_id, who.owner_filter))
    if job.status == "succeeded" and not job.bundle_path:
        raise ApiError(410, "the bundle was deleted by the retention policy (GAITMEND_BUNDLE_RETENTION_DAYS)")
    if job.status != "succeeded" or not job.bundle_path:
        raise ApiError(409, f"the bundle exists once the job succeeded; it is {job.status}", field="status")
    path = Path(job.bundle_path)
    if not path.is_file():
        raise ApiError(410, f"the bundle file is gone from the data folder: {path.name}")
    return FileResponse(path, media_type="application/zip", filename=f"gaitmend-{job.id}.zip")

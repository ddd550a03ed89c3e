"""Jobs as the user sees them: submission (idempotent, capped per owner), reads by id or
unique prefix, history and checkpoints, and the user's actions (cancel, retry, delete)."""

from __future__ import annotations

import datetime as dt
import re
import uuid

from sqlalchemy import delete, func, select, text, update
from sqlalchemy.orm import Session

from app.store.models import Job, JobCheckpoint, JobHistory, utcnow
from app.store.repo.state import assign, to_final


class NotFound(LookupError):
    pass


class Conflict(ValueError):
    """The job's state (or an earlier request) does not allow this; ``field`` is what is at odds."""

    def __init__(self, message: str, field: str = "status"):
        super().__init__(message)
        self.field = field


class QueueFull(Exception):
    def __init__(self, queued: int, limit: int):
        super().__init__(f"{queued} jobs already queued; the limit is {limit}")
        self.queued, self.limit = queued, limit


def new_job_id() -> str:
    return uuid.uuid4().hex


def find_by_idempotency_key(s: Session, owner: str, key: str) -> Job | None:
    return s.scalar(select(Job).where(Job.owner == owner, Job.idempotency_key == key))


def count_queued(s: Session, owner: str, cap: int | None = None) -> int:
    """Queued jobs of an owner, counted up to `cap` (a limit check need not count further).
    Study points not yet admitted (held) do not count: app/studies/fair.py admits them."""
    q = select(Job.seq).where(Job.owner == owner, Job.status == "queued", Job.held.is_(False))
    if cap is not None:
        q = q.limit(cap)
    return s.scalar(select(func.count()).select_from(q.subquery()))


def lock_owner(s: Session, owner: str) -> None:
    """Serialise submissions of one owner until this transaction ends, so "count the queued
    jobs, then insert" and "look up the Idempotency-Key, then insert" hold with any number
    of API processes. PostgreSQL: a transaction-scoped advisory lock on the owner's name
    (READ COMMITTED alone lets 50 concurrent requests all see 9 queued jobs). SQLite: the
    write transaction is BEGIN IMMEDIATE (app.store.db), a database-wide lock already."""
    if s.get_bind().dialect.name == "postgresql":
        s.execute(text("SELECT pg_advisory_xact_lock(:ns, hashtext(:owner))"), {"ns": _SUBMIT_LOCK_NS, "owner": owner})


_SUBMIT_LOCK_NS = 0x67616974  # "gait": keeps these locks apart from any other advisory lock user


def submit_job(s: Session, *, owner: str, kind: str, robot: str | None, spec: dict, evaluations_budget: int,
               max_attempts: int, max_queued: int, idempotency_key: str | None = None) -> tuple[Job, bool]:
    """(job, created). The same Idempotency-Key with the same spec gives the first job back;
    with another spec it is a Conflict. QueueFull when the owner has max_queued jobs queued."""
    lock_owner(s, owner)
    if idempotency_key and (job := find_by_idempotency_key(s, owner, idempotency_key)) is not None:
        if job.spec != spec:
            raise Conflict("Idempotency-Key was used before with a different spec", field="Idempotency-Key")
        return job, False
    if (queued := count_queued(s, owner, cap=max_queued)) >= max_queued:
        raise QueueFull(queued, max_queued)
    job = create_job(s, owner=owner, kind=kind, robot=robot, spec=spec, evaluations_budget=evaluations_budget,
                     max_attempts=max_attempts, idempotency_key=idempotency_key)
    job.dispatched_at = utcnow()
    return job, True


def create_job(s: Session, *, owner: str, kind: str, robot: str | None, spec: dict, evaluations_budget: int,
               max_attempts: int, idempotency_key: str | None = None, held: bool = False) -> Job:
    job = Job(id=new_job_id(), owner=owner, kind=kind, robot=robot, status="queued", spec=spec,
              idempotency_key=idempotency_key, evaluations_budget=evaluations_budget, max_attempts=max_attempts,
              attempt=0, cancel_requested=False, progress_done=0, progress_total=0, held=held)
    s.add(job)
    s.flush()
    return job


def mark_dispatched(s: Session, job_ids: list[str], now: dt.datetime | None = None) -> None:
    if job_ids:
        s.execute(update(Job).where(Job.id.in_(job_ids)).values(dispatched_at=now or utcnow()))


MIN_PREFIX = 6


_HEX_PREFIX = re.compile(r"[0-9a-f]{%d,31}" % MIN_PREFIX)


def get_job(s: Session, job_id: str, owner: str | None = None) -> Job:
    """A job by id, or by a unique prefix of its id (at least MIN_PREFIX hex digits, as
    `gaitmend jobs` prints them); owner None means any owner. Someone else's job is
    NotFound, like a missing one; a prefix shared by several jobs is a Conflict."""
    q = select(Job).where(Job.id == job_id)
    if owner is not None:
        q = q.where(Job.owner == owner)
    job = s.scalar(q)
    if job is None and _HEX_PREFIX.fullmatch(job_id):
        q = select(Job).where(Job.id >= job_id, Job.id < job_id + "g")  # an index range scan, no LIKE escaping
        if owner is not None:
            q = q.where(Job.owner == owner)
        found = list(s.scalars(q.limit(2)))
        if len(found) > 1:
            raise Conflict(f"{job_id!r} is the start of several job ids; give more of it", field="id")
        job = found[0] if found else None
    if job is None:
        raise NotFound(job_id)
    return job


def history(s: Session, job: Job) -> list[dict]:
    rows = s.scalars(select(JobHistory).where(JobHistory.job_seq == job.seq).order_by(JobHistory.generation))
    return [r.data for r in rows]


def load_checkpoint(s: Session, job_id: str) -> str | None:
    data = s.scalar(select(JobCheckpoint.data).join(Job, Job.seq == JobCheckpoint.job_seq).where(Job.id == job_id))
    return data or None  # "": the job succeeded and its checkpoint's data was dropped


def checkpoint_saves(s: Session, job_id: str) -> int:
    return s.scalar(select(JobCheckpoint.saves).join(Job, Job.seq == JobCheckpoint.job_seq).where(Job.id == job_id)) or 0


def request_cancel(s: Session, job_id: str, owner: str | None) -> Job:
    """Queued: cancelled now, it never starts. Running: flagged, the search stops at its next
    generation. Finished: unchanged."""
    job = get_job(s, job_id, owner)
    now = utcnow()
    if job.status == "queued":
        to_final(job, "cancelled", now)
        job.cancel_requested = True
    elif job.status == "running":
        job.cancel_requested = True
        job.updated_at = now
    return job


def retry(s: Session, job_id: str, owner: str | None) -> Job:
    """Failed or cancelled jobs run again, resuming from their last checkpoint if any."""
    job = get_job(s, job_id, owner)
    if job.status not in ("failed", "cancelled"):
        raise Conflict(f"only failed or cancelled jobs can be retried; this one is {job.status}", field="status")
    assign(job, status="queued", attempt=0, cancel_requested=False, error=None, summary=None, bundle_path=None,
            finished_at=None, dispatched_at=None, updated_at=utcnow(), held=False, interrupted_at=None)
    return job


def delete_job(s: Session, job_id: str, owner: str | None) -> Job:
    job = get_job(s, job_id, owner)
    if job.status == "running":
        raise Conflict("the job is running; cancel it first", field="status")
    s.execute(delete(JobHistory).where(JobHistory.job_seq == job.seq))
    s.execute(delete(JobCheckpoint).where(JobCheckpoint.job_seq == job.seq))
    s.delete(job)
    return job

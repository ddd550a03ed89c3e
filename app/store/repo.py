"""Repository functions: every read and write of the service goes through here, each in
the caller's short transaction (see db.session_scope). Writes by a running job are fenced
by its lease token, so a worker that lost its lease can no longer change the job."""

from __future__ import annotations

import base64
import dataclasses
import datetime as dt
import hashlib
import re
import secrets
import uuid
from sqlalchemy import delete, func, select, text, update
from sqlalchemy.orm import Session

from app.store.models import FINAL, ApiToken, Job, JobCheckpoint, JobHistory, Worker, utcnow


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


# -- submission ------------------------------------------------------------------------------

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


# -- reads ---------------------------------------------------------------------------------------

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


# A cursor is the seq of the last job shown, as decimal digits: every string the OpenAPI
# pattern allows is a cursor (pages before it), so the document does not promise more than
# the route keeps. jobs.seq is a 32-bit integer on both backends: a larger cursor is
# clamped, never passed on (OverflowError on SQLite, NumericValueOutOfRange on PostgreSQL).
MAX_SEQ = 2**31 - 1
CURSOR_PATTERN = r"^[0-9]{1,19}$"


def encode_cursor(seq: int) -> str:
    return str(seq)


def decode_cursor(cursor: str) -> int | None:
    """The seq to page before; None when the cursor lies beyond every seq (no bound)."""
    if not re.fullmatch(CURSOR_PATTERN, cursor):
        raise ValueError("not a cursor returned by this API (pass next_cursor from the previous page)")
    return int(cursor) if int(cursor) <= MAX_SEQ else None


def list_jobs(s: Session, *, owner: str | None, status: str | None = None, kind: str | None = None,
              robot: str | None = None, limit: int = 50, before_seq: int | None = None) -> tuple[list[Job], int | None]:
    """Newest first; keyset pagination on seq, so page N costs the same as page 1."""
    q = select(Job)
    if owner is not None:
        q = q.where(Job.owner == owner)
    if status:
        q = q.where(Job.status == status)
    if kind:
        q = q.where(Job.kind == kind)
    if robot:
        q = q.where(Job.robot == robot)
    if before_seq is not None:
        q = q.where(Job.seq < before_seq)
    rows = list(s.scalars(q.order_by(Job.seq.desc()).limit(limit + 1)))
    nxt = rows[limit - 1].seq if len(rows) > limit else None
    return rows[:limit], nxt


def history(s: Session, job: Job) -> list[dict]:
    rows = s.scalars(select(JobHistory).where(JobHistory.job_seq == job.seq).order_by(JobHistory.generation))
    return [r.data for r in rows]


def load_checkpoint(s: Session, job_id: str) -> str | None:
    data = s.scalar(select(JobCheckpoint.data).join(Job, Job.seq == JobCheckpoint.job_seq).where(Job.id == job_id))
    return data or None  # "": the job succeeded and its checkpoint's data was dropped


def checkpoint_saves(s: Session, job_id: str) -> int:
    return s.scalar(select(JobCheckpoint.saves).join(Job, Job.seq == JobCheckpoint.job_seq).where(Job.id == job_id)) or 0


# -- the worker's side -----------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Claim:
    job_id: str
    seq: int
    lease_token: str
    attempt: int
    spec: dict


def lost_reason(attempt: int, max_attempts: int) -> str:
    return (f"worker lost {attempt} times while running this job (killed, out of memory, crashed, or cut off "
            f"from the database longer than its lease); giving up after max_attempts={max_attempts}")


def claim(s: Session, job_id: str, *, worker: str, lease_s: float, now: dt.datetime | None = None,
          token: str | None = None) -> Claim | None:
    """Take a queued job, or a running one whose lease expired, for one attempt.
    None when there is nothing to run: finished, cancelled, held by a live lease, a study
    point not yet admitted, or out of attempts (then the job is failed here, with the reason).
    `token`: the lease token to take it with; a retry after a commit whose answer was lost
    finds the job already held by that token and gets the same claim back."""
    now = now or utcnow()
    job = s.scalar(select(Job).where(Job.id == job_id).with_for_update())
    if job is None or job.status in FINAL:
        return None
    if token is not None and job.status == "running" and job.lease_token == token:
        return Claim(job.id, job.seq, job.lease_token, job.attempt, dict(job.spec))
    if job.status == "running" and job.lease_expires_at is not None and job.lease_expires_at > now:
        return None
    if job.status == "queued" and job.held:
        return None
    if job.cancel_requested:
        _finish(job, "cancelled", now)
        return None
    if job.attempt >= job.max_attempts:
        _finish(job, "failed", now, error=lost_reason(job.attempt, job.max_attempts))
        return None
    job.attempt += 1
    job.status = "running"
    job.interrupted_at = None
    job.lease_token = token or uuid.uuid4().hex
    job.lease_expires_at = now + dt.timedelta(seconds=lease_s)
    job.worker = worker
    job.started_at = job.started_at or now
    job.updated_at = now
    return Claim(job.id, job.seq, job.lease_token, job.attempt, dict(job.spec))


def _fenced(job_id: str, token: str):
    return update(Job).where(Job.id == job_id, Job.lease_token == token, Job.status == "running")


def heartbeat(s: Session, job_id: str, token: str, lease_s: float) -> bool:
    now = utcnow()
    r = s.execute(_fenced(job_id, token).values(lease_expires_at=now + dt.timedelta(seconds=lease_s)))
    return r.rowcount == 1


def record_progress(s: Session, claim_: Claim, done: int, total: int, info: dict, lease_s: float) -> bool:
    now = utcnow()
    r = s.execute(_fenced(claim_.job_id, claim_.lease_token).values(
        progress_done=done, progress_total=total, progress_info=info, updated_at=now,
        lease_expires_at=now + dt.timedelta(seconds=lease_s)))
    if r.rowcount != 1:
        return False
    gen = max(done - 1, 0)
    row = s.get(JobHistory, (claim_.seq, gen))
    if row is None:
        s.add(JobHistory(job_seq=claim_.seq, generation=gen, data={"generation": gen} | info))
    else:
        row.data = {"generation": gen} | info
    return True


def save_checkpoint(s: Session, claim_: Claim, data: str) -> bool:
    r = s.execute(_fenced(claim_.job_id, claim_.lease_token).values(updated_at=utcnow()))
    if r.rowcount != 1:
        return False
    row = s.get(JobCheckpoint, claim_.seq)
    if row is None:
        s.add(JobCheckpoint(job_seq=claim_.seq, saves=1, data=data, updated_at=utcnow()))
    else:
        row.data, row.saves, row.updated_at = data, row.saves + 1, utcnow()
    return True


def cancel_requested(s: Session, job_id: str) -> bool:
    return bool(s.scalar(select(Job.cancel_requested).where(Job.id == job_id)))


def job_flags(s: Session, job_id: str) -> tuple[bool, bool]:
    """(cancel requested, the worker running it was asked to stop)."""
    row = s.execute(select(Job.cancel_requested, Job.interrupted_at).where(Job.id == job_id)).first()
    return (False, False) if row is None else (bool(row[0]), row[1] is not None)


def mark_interrupted(s: Session, claim_: Claim) -> bool:
    """The worker running this claim was asked to stop (fenced by the lease)."""
    r = s.execute(_fenced(claim_.job_id, claim_.lease_token).where(Job.interrupted_at.is_(None))
                  .values(interrupted_at=utcnow()))
    return r.rowcount == 1


def interrupt_workers(s: Session, workers: list[str]) -> dict[str, str]:
    """Mark the running jobs of these worker processes (host:pid) as interrupted: their
    worker is stopping. Returns {job id: worker process} of the jobs marked."""
    if not workers:
        return {}
    found = dict(s.execute(select(Job.id, Job.worker).where(Job.status == "running", Job.worker.in_(workers),
                                                             Job.interrupted_at.is_(None))).all())
    if found:
        s.execute(update(Job).where(Job.id.in_(list(found)), Job.status == "running").values(interrupted_at=utcnow()))
    return found


def release(s: Session, claim_: Claim, refund: bool = True) -> bool:
    """Hand a running job back to the queue: it resumes from its last checkpoint elsewhere.
    `refund`: the attempt is not spent (its worker is stopping). Fenced: False when the
    lease is no longer this claim's."""
    job = s.scalar(select(Job).where(Job.id == claim_.job_id, Job.lease_token == claim_.lease_token,
                                     Job.status == "running").with_for_update())
    if job is None:
        return False
    _requeue(job, utcnow(), refund=refund)
    return True


def _requeue(job: Job, now: dt.datetime, refund: bool) -> None:
    _assign(job, status="queued", lease_token=None, lease_expires_at=None, dispatched_at=None, updated_at=now,
            interrupted_at=None, attempt=max(job.attempt - 1, 0) if refund else job.attempt)


def _assign(job: Job, **values: object) -> None:
    for name, value in values.items():
        setattr(job, name, value)


def _finish(job: Job, status: str, now: dt.datetime, error: str | None = None) -> None:
    _assign(job, status=status, error=error, finished_at=now, updated_at=now, lease_token=None, lease_expires_at=None,
            interrupted_at=None, held=False)


def finish(s: Session, claim_: Claim, status: str, *, summary: dict | None = None, error: str | None = None,
           bundle_path: str | None = None, history_rows: list[dict] | None = None) -> bool:
    assert status in FINAL
    job = s.scalar(select(Job).where(Job.id == claim_.job_id, Job.lease_token == claim_.lease_token,
                                     Job.status == "running").with_for_update())
    if job is None:
        return False
    _finish(job, status, utcnow(), error=error)
    job.summary = summary
    job.bundle_path = bundle_path
    if history_rows is not None:
        s.execute(delete(JobHistory).where(JobHistory.job_seq == job.seq))
        s.add_all(JobHistory(job_seq=job.seq, generation=i, data=r) for i, r in enumerate(history_rows))
    if status == "succeeded":
        job.progress_done = job.progress_total = max(job.progress_total, job.progress_done)
        # Nothing resumes a succeeded job (retry takes failed or cancelled ones only): its
        # checkpoint's data goes now; the row stays with its count of saves until the
        # checkpoint retention (a record of how often the job was checkpointed).
        s.execute(update(JobCheckpoint).where(JobCheckpoint.job_seq == job.seq).values(data=""))
    return True


def finished_as(s: Session, job_id: str) -> str | None:
    """The job's status when it is final (a finish whose commit answer was lost may have
    gone through), else None."""
    status = s.scalar(select(Job.status).where(Job.id == job_id))
    return status if status in FINAL else None


# -- reaper --------------------------------------------------------------------------------------

def reap(s: Session, now: dt.datetime | None = None) -> list[str]:
    """Jobs whose lease expired go back to the queue (or fail, out of attempts, or become
    cancelled if that was asked). Returns the ids to dispatch again."""
    now = now or utcnow()
    q = select(Job).where(Job.status == "running", Job.lease_expires_at < now).with_for_update(skip_locked=True)
    requeued = []
    for job in s.scalars(q):
        # A worker that was asked to stop and died before handing the job back (SIGTERM,
        # then SIGKILL) did not fail because of the job: its attempt is given back.
        refund = job.interrupted_at is not None
        if job.cancel_requested:
            _finish(job, "cancelled", now)
        elif job.attempt >= job.max_attempts and not refund:
            _finish(job, "failed", now, error=lost_reason(job.attempt, job.max_attempts))
        else:
            _requeue(job, now, refund=refund)
            requeued.append(job.id)
    return requeued


def undispatch_before(s: Session, before: dt.datetime) -> list[str]:
    """Queued jobs whose message was sent before `before` (when the broker restarted: it
    cannot hold them unless it persisted them) become unsent, so they are sent again and no
    longer count against the owner's dispatch window."""
    ids = list(s.scalars(select(Job.id).where(Job.status == "queued", Job.dispatched_at < before)))
    if ids:
        s.execute(update(Job).where(Job.id.in_(ids), Job.status == "queued", Job.dispatched_at < before)
                  .values(dispatched_at=None))
    return ids


def running_count(s: Session) -> int:
    return s.scalar(select(func.count()).select_from(Job).where(Job.status == "running"))


def waiting(s: Session, older_than: dt.datetime) -> tuple[int, dt.datetime | None]:
    """Admitted queued jobs waiting since before `older_than` (count, oldest wait start)."""
    q = select(func.count(), func.min(Job.updated_at)).where(Job.status == "queued", Job.held.is_(False),
                                                             Job.updated_at < older_than)
    n, oldest = s.execute(q).one()
    if isinstance(oldest, dt.datetime) and oldest.tzinfo is None:
        oldest = oldest.replace(tzinfo=dt.timezone.utc)
    return n, oldest


def stale_dispatched(s: Session, before: dt.datetime) -> int:
    """Admitted queued jobs whose message went out before `before` and is not yet claimed."""
    return s.scalar(select(func.count()).select_from(Job).where(
        Job.status == "queued", Job.held.is_(False), Job.dispatched_at < before))


# -- retention ---------------------------------------------------------------------------------

def expired_bundles(s: Session, finished_before: dt.datetime, limit: int = 500) -> list[tuple[str, str]]:
    """(job id, bundle path) of finished jobs past the bundle retention."""
    q = (select(Job.id, Job.bundle_path).where(Job.status.in_(FINAL), Job.bundle_path.is_not(None),
                                                Job.finished_at < finished_before).order_by(Job.seq).limit(limit))
    return [(i, p) for i, p in s.execute(q)]


def forget_bundles(s: Session, job_ids: list[str]) -> None:
    """The bundles of these jobs were deleted (retention)."""
    if job_ids:
        s.execute(update(Job).where(Job.id.in_(job_ids)).values(bundle_path=None))


def running_ids(s: Session) -> list[str]:
    return list(s.scalars(select(Job.id).where(Job.status == "running")))


def drop_checkpoints(s: Session, finished_before: dt.datetime) -> int:
    """Checkpoints of finished jobs past the checkpoint retention (a retry then starts over)."""
    seqs = select(Job.seq).where(Job.status.in_(FINAL), Job.finished_at < finished_before).scalar_subquery()
    return s.execute(delete(JobCheckpoint).where(JobCheckpoint.job_seq.in_(seqs))).rowcount or 0


def undelivered(s: Session, after_s: float, now: dt.datetime | None = None, limit: int = 500) -> list[str]:
    """Queued jobs whose message was never sent or was sent long ago (the embedded broker
    drops a message that a killed worker had taken but not yet claimed)."""
    now = now or utcnow()
    cutoff = now - dt.timedelta(seconds=after_s)
    q = (select(Job.id).where(Job.status == "queued", Job.held.is_(False),
                              (Job.dispatched_at.is_(None)) | (Job.dispatched_at < cutoff))
         .order_by(Job.seq).limit(limit))
    return list(s.scalars(q))


# -- user actions --------------------------------------------------------------------------------

def request_cancel(s: Session, job_id: str, owner: str | None) -> Job:
    """Queued: cancelled now, it never starts. Running: flagged, the search stops at its next
    generation. Finished: unchanged."""
    job = get_job(s, job_id, owner)
    now = utcnow()
    if job.status == "queued":
        _finish(job, "cancelled", now)
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
    _assign(job, status="queued", attempt=0, cancel_requested=False, error=None, summary=None, bundle_path=None,
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


# -- tokens ----------------------------------------------------------------------------------------

def hash_token(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def create_token(s: Session, name: str) -> str:
    if s.scalar(select(ApiToken).where(ApiToken.name == name)) is not None:
        raise Conflict(f"a token named {name!r} exists; revoke it first", field="name")
    token = "gm_" + secrets.token_urlsafe(32)
    s.add(ApiToken(name=name, token_hash=hash_token(token)))
    return token


def resolve_token(s: Session, token: str) -> str | None:
    found = resolve_token_id(s, token)
    return found[0] if found else None


def resolve_token_id(s: Session, token: str) -> tuple[str, int] | None:
    """(owner name, token row id) of a live token."""
    row = s.scalar(select(ApiToken).where(ApiToken.token_hash == hash_token(token)))
    if row is None:
        return None
    now = utcnow()
    if row.last_used_at is None or (now - row.last_used_at).total_seconds() > 60:
        row.last_used_at = now  # at most one write a minute per token
    return row.name, row.id


def token_owner(s: Session, token_id: int) -> str | None:
    """The owner of a token that still exists (signed links die with their token)."""
    return s.scalar(select(ApiToken.name).where(ApiToken.id == token_id))


def list_tokens(s: Session) -> list[ApiToken]:
    return list(s.scalars(select(ApiToken).order_by(ApiToken.id)))


def revoke_token(s: Session, name: str) -> bool:
    return s.execute(delete(ApiToken).where(ApiToken.name == name)).rowcount == 1


def token_count(s: Session) -> int:
    return s.scalar(select(func.count()).select_from(ApiToken))


# -- workers ------------------------------------------------------------------------------------

def worker_seen(s: Session, name: str, broker: str, slots: int = 1) -> None:
    now = utcnow()
    row = s.get(Worker, name)
    if row is None:
        s.add(Worker(name=name, broker=broker, started_at=now, last_seen_at=now, slots=slots))
    else:
        row.last_seen_at, row.slots = now, slots


def worker_gone(s: Session, name: str) -> None:
    """A worker that stops (or lost its broker) is no longer counted as live."""
    s.execute(delete(Worker).where(Worker.name == name))


def idle_slots(s: Session, within_s: float) -> tuple[int, int]:
    """(task slots of the live workers, jobs running)."""
    slots = sum(w.slots or 1 for w in workers_seen(s, within_s))
    return slots, running_count(s)


def workers_seen(s: Session, within_s: float) -> list[Worker]:
    cutoff = utcnow() - dt.timedelta(seconds=within_s)
    return list(s.scalars(select(Worker).where(Worker.last_seen_at >= cutoff).order_by(Worker.name)))


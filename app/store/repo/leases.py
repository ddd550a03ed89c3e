"""The lease protocol: how a worker holds a job, and how a job that lost its worker comes back.

One protocol, written here once (app/service/runner.py runs it; docs/faults.md tells the faults):

1. **Claim.** ``claim`` takes a queued job (or a running one whose lease expired) in one
   transaction with the row locked: it counts the attempt, sets ``status = running``, a
   fresh random ``lease_token`` and ``lease_expires_at = now + lease_s``. A claim retried
   after a commit whose answer was lost passes the same token and gets the same claim back.
   A job out of attempts is failed here, with the reason (``state.lost_reason``).
2. **Fencing.** Every later write of the running job (``heartbeat``, ``record_progress``,
   ``save_checkpoint``, ``mark_interrupted``, ``release``, ``finish``) is an UPDATE whose
   WHERE names the job, its lease token and ``status = running`` (``_fenced``). It returns
   whether one row changed: False means another worker took the job after this one's lease
   ran out, and the caller stops (runner.LeaseLost) without touching the job again.
3. **Renewal.** The worker renews the lease every third of ``lease_s`` (``heartbeat``);
   retries of a dropped connection stop where the lease would have run out, so a worker cut
   off from the database longer than its lease can no longer write.
4. **Hand-back.** A stopping worker hands the job back with ``release`` (queued again; the attempt is
   refunded unless the job itself ran out of the store's patience).
5. **Reaping.** ``reap`` returns every running job whose lease expired to the queue (or
   fails it when its attempts are spent, or cancels it when asked), so a worker killed with
   kill -9 costs the job one attempt and the time to its lease's end, never the job.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import uuid

from sqlalchemy import delete, func, select, update
from sqlalchemy.orm import Session

from app.store.models import FINAL, Job, JobCheckpoint, JobHistory, utcnow
from app.store.repo.state import lost_reason, to_final, to_queue


@dataclasses.dataclass(frozen=True)
class Claim:
    job_id: str
    seq: int
    lease_token: str
    attempt: int
    spec: dict


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
        to_final(job, "cancelled", now)
        return None
    if job.attempt >= job.max_attempts:
        to_final(job, "failed", now, error=lost_reason(job.attempt, job.max_attempts))
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
    to_queue(job, utcnow(), refund=refund)
    return True


def finish(s: Session, claim_: Claim, status: str, *, summary: dict | None = None, error: str | None = None,
           bundle_path: str | None = None, history_rows: list[dict] | None = None) -> bool:
    assert status in FINAL
    job = s.scalar(select(Job).where(Job.id == claim_.job_id, Job.lease_token == claim_.lease_token,
                                     Job.status == "running").with_for_update())
    if job is None:
        return False
    to_final(job, status, utcnow(), error=error)
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
            to_final(job, "cancelled", now)
        elif job.attempt >= job.max_attempts and not refund:
            to_final(job, "failed", now, error=lost_reason(job.attempt, job.max_attempts))
        else:
            to_queue(job, now, refund=refund)
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

"""What housekeeping removes: bundles and checkpoints of jobs finished long ago, and the
queued jobs whose broker message was lost (re-sent by the dispatcher)."""

from __future__ import annotations

import datetime as dt

from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session

from app.store.models import FINAL, Job, JobCheckpoint, utcnow


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

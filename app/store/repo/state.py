"""The states of a job row and the moves between them, shared by the lease protocol
(leases.py), the reaper (leases.py) and the user's actions (jobs.py):

    queued --claim--> running --finish--> succeeded | failed | cancelled
       ^                 |  release / reap (lease expired): back to queued, the attempt refunded or not
       +-----------------+
    failed | cancelled --retry--> queued (attempts reset)

A move clears the lease (token, expiry) whenever the job leaves ``running``."""

from __future__ import annotations

import datetime as dt

from app.store.models import Job


def lost_reason(attempt: int, max_attempts: int) -> str:
    return (f"worker lost {attempt} times while running this job (killed, out of memory, crashed, or cut off "
            f"from the database longer than its lease); giving up after max_attempts={max_attempts}")


def to_queue(job: Job, now: dt.datetime, refund: bool) -> None:
    assign(job, status="queued", lease_token=None, lease_expires_at=None, dispatched_at=None, updated_at=now,
            interrupted_at=None, attempt=max(job.attempt - 1, 0) if refund else job.attempt)


def assign(job: Job, **values: object) -> None:
    for name, value in values.items():
        setattr(job, name, value)


def to_final(job: Job, status: str, now: dt.datetime, error: str | None = None) -> None:
    assign(job, status=status, error=error, finished_at=now, updated_at=now, lease_token=None, lease_expires_at=None,
            interrupted_at=None, held=False)

"""The jobs list: newest first, filtered by owner, status and kind, paged by an opaque
cursor (the job's sequence number)."""

from __future__ import annotations

import re

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.store.models import Job


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

"""Workers seen by the store: their heartbeats, free slots and the ones gone quiet."""

from __future__ import annotations

import datetime as dt

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from app.store.models import Worker, utcnow
from app.store.repo.leases import running_count


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

"""Fair dispatch. The policy: the broker holds at most ``window`` messages per owner
(window = GAITMEND_DISPATCH_WINDOW_PER_OWNER, default 2 x the live worker processes, at
least 2); further queued jobs wait in the jobs table unsent, and each refill (the
housekeeper's pass, and every worker after each job it finishes) sends the owners' next
jobs in round robin, oldest first within an owner. So another owner's single job waits
behind at most ``window`` messages of a 500-point study, not behind all 500."""

from __future__ import annotations

import datetime as dt
import os

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.store import repo
from app.store.models import Job, utcnow


def window(s: Session, reaper_interval_s: float) -> int:
    if v := os.environ.get("GAITMEND_DISPATCH_WINDOW_PER_OWNER"):
        return max(1, int(v))
    live = len(repo.workers_seen(s, within_s=max(3 * reaper_interval_s, 15.0)))
    return max(2, 2 * live)


def select_fair(s: Session, redispatch_after_s: float, win: int, now: dt.datetime | None = None,
                limit: int = 500) -> list[str]:
    """Ids to send now: per owner, up to ``win`` minus the messages already in the broker
    (queued jobs sent within ``redispatch_after_s``), interleaved owner by owner."""
    now = now or utcnow()
    cutoff = now - dt.timedelta(seconds=redispatch_after_s)
    inflight = dict(s.execute(select(Job.owner, func.count()).where(Job.status == "queued", Job.dispatched_at >= cutoff)
                              .group_by(Job.owner)).all())
    due = (Job.status == "queued") & (Job.dispatched_at.is_(None) | (Job.dispatched_at < cutoff))
    owners = list(s.scalars(select(Job.owner).where(due).group_by(Job.owner).order_by(func.min(Job.seq))))
    per_owner = []
    for o in owners:
        room = win - inflight.get(o, 0)
        if room > 0:
            per_owner.append(list(s.scalars(select(Job.id).where(due, Job.owner == o).order_by(Job.seq).limit(room))))
    out: list[str] = []
    for i in range(max((len(x) for x in per_owner), default=0)):  # round robin over owners
        out += [x[i] for x in per_owner if i < len(x)]
    return out[:limit]

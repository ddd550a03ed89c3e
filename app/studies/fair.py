"""Fair dispatch and study feeding.

The broker holds at most ``window`` messages per owner (window =
GAITMEND_DISPATCH_WINDOW_PER_OWNER, default 2 x the live worker processes, at least 2);
further queued jobs wait in the jobs table unsent, and each refill (the housekeeper's
pass, and every worker after each job it finishes) sends the owners' next jobs in round
robin, oldest first within an owner. So another owner's single job waits behind at most
``window`` messages of a 500-point study, not behind all 500.

A message counts against the window while its job is queued with a dispatch time. The
dispatch time is cleared whenever the message cannot be in the broker (the send failed,
the broker restarted: app/service/dispatch.py), and a message older than
GAITMEND_REDISPATCH_AFTER_S is sent again when the caller says messages are being lost
(``stale_before``).

Studies: every point is a job row from the start, but a point is *held* (shown as
queued, not counted against GAITMEND_MAX_QUEUED_PER_OWNER, never sent) until ``feed``
admits it: an owner's studies fill at most half the owner's queue limit, so a study of
any size is accepted and the owner can still submit single jobs beside it.
"""

from __future__ import annotations

import datetime as dt
import os

from sqlalchemy import func, select, update
from sqlalchemy.orm import Session

from app.store import repo
from app.store.models import Job, utcnow


def window(s: Session, reaper_interval_s: float) -> int:
    if v := os.environ.get("GAITMEND_DISPATCH_WINDOW_PER_OWNER"):
        return max(1, int(v))
    live = len(repo.workers_seen(s, within_s=live_within_s(reaper_interval_s)))
    return max(2, 2 * live)


def live_within_s(reaper_interval_s: float) -> float:
    """A worker is live when seen within three housekeeping intervals (at least 15 s)."""
    return max(3 * reaper_interval_s, 15.0)


def study_share(max_queued: int) -> int:
    """How many admitted queued jobs an owner's studies may hold at once."""
    return max(1, max_queued // 2)


def select_fair(s: Session, win: int, now: dt.datetime | None = None, limit: int = 500,
                stale_before: dt.datetime | None = None) -> list[str]:
    """Ids to send now: per owner, up to ``win`` minus the messages already in the broker,
    interleaved owner by owner. With ``stale_before``, a message sent before it is presumed
    lost: it is sent again and no longer counts."""
    admitted = (Job.status == "queued") & Job.held.is_(False)
    unsent = Job.dispatched_at.is_(None)
    if stale_before is not None:
        unsent = unsent | (Job.dispatched_at < stale_before)
    due = admitted & unsent
    inflight = dict(s.execute(select(Job.owner, func.count()).where(admitted & ~unsent).group_by(Job.owner)).all())
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


def feed(s: Session, max_queued: int, owner: str | None = None) -> int:
    """Admit held study points, oldest first, while each owner has fewer than
    ``study_share(max_queued)`` admitted queued jobs. Returns how many were admitted."""
    share = study_share(max_queued)
    q = select(Job.owner).where(Job.status == "queued", Job.held.is_(True)).group_by(Job.owner)
    owners = [owner] if owner is not None else list(s.scalars(q))
    admitted = 0
    for o in owners:
        repo.lock_owner(s, o)  # against a concurrent submission or another feeder
        room = share - repo.count_queued(s, o, cap=share)
        if room <= 0:
            continue
        ids = list(s.scalars(select(Job.id).where(Job.owner == o, Job.status == "queued", Job.held.is_(True))
                             .order_by(Job.seq).limit(room)))
        if ids:
            s.execute(update(Job).where(Job.id.in_(ids), Job.held.is_(True))
                      .values(held=False, dispatched_at=None, updated_at=utcnow()))
            admitted += len(ids)
    return admitted

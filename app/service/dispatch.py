"""Sending job ids to the broker. The row is committed first; a send that fails leaves
the job queued with no dispatch time, and the housekeeper sends it again."""

from __future__ import annotations

import functools
import logging
import time

from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope

log = logging.getLogger("gaitmend.dispatch")

TASK = "gaitmend.run_job"


@functools.lru_cache(maxsize=8)
def _celery(settings: Settings):
    from app.service.broker import ensure_broker_folder, make_celery

    ensure_broker_folder(settings)
    return make_celery(settings, sender=True)


# After a failed send, submissions skip the broker for this long (the jobs stay queued and
# the housekeeper sends them), so an unreachable Redis costs one request one short try,
# not every request a timeout.
BROKER_DOWN_S = 5.0
_down_until: dict[str, float] = {}


def send(settings: Settings, job_ids: list[str]) -> list[str]:
    """Send each id; returns those that could not be sent (their dispatch time is cleared)."""
    failed = []
    if time.monotonic() < _down_until.get(settings.broker_url, 0.0):
        failed = list(job_ids)
    else:
        app = _celery(settings)
        for i, job_id in enumerate(job_ids):
            try:
                app.send_task(TASK, args=[job_id], queue=settings.queue, retry=False)
            except Exception as e:
                log.warning("could not send job %s to the broker (%s); it stays queued and is sent again later",
                            job_id, e)
                _down_until[settings.broker_url] = time.monotonic() + BROKER_DOWN_S
                failed.extend(job_ids[i:])
                break
        else:
            _down_until.pop(settings.broker_url, None)
    if failed:
        from sqlalchemy import update

        from app.store.models import Job

        with session_scope(settings.db_url) as s:
            s.execute(update(Job).where(Job.id.in_(failed)).values(dispatched_at=None))
    return failed


def broker_ok(settings: Settings) -> tuple[bool, str]:
    app = _celery(settings)
    try:
        with app.connection_for_write() as conn:
            conn.ensure_connection(max_retries=1, timeout=2)
        return True, "ok"
    except Exception as e:
        return False, f"{type(e).__name__}: {e}"


def fair_next(s, settings: Settings) -> list[str]:
    """Queued jobs to send now, per-owner round robin (the policy: app/studies/fair.py)."""
    from app.studies.fair import select_fair, window

    return select_fair(s, settings.redispatch_after_s, window(s, settings.reaper_interval_s))


def refill(settings: Settings) -> int:
    """Send the next fair share of queued jobs (after a job finished: its slot is free)."""
    with session_scope(settings.db_url) as s:
        ids = fair_next(s, settings)
        repo.mark_dispatched(s, ids)
    send(settings, ids)
    return len(ids)


def dispatch_pending(settings: Settings) -> int:
    """Requeue jobs whose lease expired and (re)send messages that are missing."""
    with session_scope(settings.db_url) as s:
        requeued = repo.reap(s)
    with session_scope(settings.db_url) as s:
        ids = fair_next(s, settings)
        repo.mark_dispatched(s, ids)
    if requeued:
        log.info("requeued after lost lease: %s", requeued)
    send(settings, ids)
    return len(ids)

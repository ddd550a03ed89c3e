"""Sending job ids to the broker. The row is committed first; a send that fails leaves
the job queued with no dispatch time, and the housekeeper sends it again."""

from __future__ import annotations

import datetime as dt
import functools
import logging
import os
import time

from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope
from app.store.models import utcnow

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


def fair_next(s, settings: Settings, stale_before=None) -> list[str]:
    """Queued jobs to send now, per-owner round robin (the policy: app/studies/fair.py)."""
    from app.studies.fair import select_fair, window

    return select_fair(s, window(s, settings.reaper_interval_s), stale_before=stale_before)


def refill(settings: Settings) -> int:
    """Admit held study points and send the next fair share of queued jobs (after a job
    finished: its slot is free)."""
    from app.studies.fair import feed

    with session_scope(settings.db_url) as s:
        feed(s, settings.max_queued_per_owner)
    with session_scope(settings.db_url) as s:
        ids = fair_next(s, settings)
        repo.mark_dispatched(s, ids)
    send(settings, ids)
    return len(ids)


# -- what the broker holds ----------------------------------------------------------------------

@functools.lru_cache(maxsize=8)
def _redis(url: str):
    import redis

    return redis.Redis.from_url(url, socket_connect_timeout=1.0, socket_timeout=2.0)


def broker_facts(settings: Settings) -> tuple[dt.datetime | None, int | None]:
    """(when the broker process started, messages waiting in the queue), each None when
    unknown. Redis: INFO's uptime and LLEN of the queue's lists. Embedded: the message files."""
    if settings.embedded_broker:
        folder = settings.broker_dir.resolve()
        suffix = f".{settings.queue}.msg"
        try:
            return None, sum(1 for n in os.listdir(folder) if n.endswith(suffix))
        except OSError:
            return None, None
    try:
        r = _redis(settings.broker_connection_url)
        info = r.info("server")
        started = utcnow() - dt.timedelta(seconds=int(info["uptime_in_seconds"]) + 1)
        key = settings.redis_key_prefix + settings.queue
        # kombu's priority lists: the queue name, then name + "\x06\x16" + priority
        keys = [key] + [f"{key}\x06\x16{p}" for p in (3, 6, 9)]
        waiting = sum(int(n) for n in _pipeline_llen(r, keys))
        return started, waiting
    except Exception as e:  # noqa: BLE001  (the broker is away: nothing to learn now)
        log.debug("broker facts unavailable: %s", e)
        return None, None


def _pipeline_llen(r, keys: list[str]) -> list[int]:
    p = r.pipeline(transaction=False)
    for k in keys:
        p.llen(k)
    return p.execute()


def _stale_before(settings: Settings, waiting_in_broker: int | None) -> dt.datetime | None:
    """The dispatch time before which a queued job's message is presumed lost, or None
    when nothing says messages are being lost. A message sent GAITMEND_REDISPATCH_AFTER_S
    ago and not claimed is lost when a worker slot is idle (an idle worker would have taken
    it within a second), or when the broker holds fewer messages than such jobs."""
    from app.studies.fair import live_within_s

    cutoff = utcnow() - dt.timedelta(seconds=settings.redispatch_after_s)
    with session_scope(settings.db_url, readonly=True) as s:
        stale = repo.stale_dispatched(s, cutoff)
        if not stale:
            return None
        slots, running = repo.idle_slots(s, live_within_s(settings.reaper_interval_s))
    if slots > running or (waiting_in_broker is not None and waiting_in_broker < stale):
        log.info("%d queued job(s) sent over %.0f s ago and not claimed (%d of %d worker slots busy, %s message(s) "
                 "in the broker): sending them again", stale, settings.redispatch_after_s, running, slots,
                 "?" if waiting_in_broker is None else waiting_in_broker)
        return cutoff
    return None


def dispatch_pending(settings: Settings) -> int:
    """Requeue jobs whose lease expired, admit held study points, and (re)send messages
    that are missing: never sent, sent to a broker that restarted since, or presumed lost."""
    from app.studies.fair import feed

    with session_scope(settings.db_url) as s:
        requeued = repo.reap(s)
    if requeued:
        log.info("requeued after lost lease: %s", requeued)
    started, waiting_in_broker = broker_facts(settings)
    if started is not None:
        with session_scope(settings.db_url) as s:
            lost = repo.undispatch_before(s, started)
        if lost:
            log.warning("the broker restarted at %s: sending the messages of %d queued job(s) again",
                        started.isoformat(timespec="seconds"), len(lost))
    with session_scope(settings.db_url) as s:
        feed(s, settings.max_queued_per_owner)
    stale_before = _stale_before(settings, waiting_in_broker)
    with session_scope(settings.db_url) as s:
        ids = fair_next(s, settings, stale_before)
        repo.mark_dispatched(s, ids)
    send(settings, ids)
    return len(ids)

"""What /api/health reports (the route: app/api/routes/meta.py): the database, the broker,
the live workers, and the reasons the service is "degraded":

- the database or the broker cannot be reached;
- jobs have waited longer than GAITMEND_STALL_AFTER_S while worker slots sit idle, or no
  worker is connected to the broker (a stalled cluster is never "ok");
- the data folder has less than GAITMEND_MIN_FREE_MB free.

A worker is live while its consumer is connected to the broker (app/service/consumer.py).
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any, ContextManager

from sqlalchemy import text

from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope
from app.store.errors import safe_message
from app.store.models import utcnow
from app.store.space import free_bytes, human


def assess(settings: Settings, session: Callable[..., ContextManager] | None = None) -> dict[str, Any]:
    """{"status", "reasons", "database", "broker", "workers" (rows), "disk", "queue"}.
    `session(readonly=True)`: the transaction to read in (the API's database dependency);
    default app/store/db.py's session_scope on the settings' database."""
    from app.service.dispatch import broker_ok
    from app.studies.fair import live_within_s

    reasons: list[str] = []
    workers: list = []
    queue: dict[str, Any] = {}
    try:
        opened = session(readonly=True) if session else session_scope(settings.db_url, readonly=True)
        with opened as s:
            s.execute(text("SELECT 1"))
            seen = [SimpleNamespace(name=w.name, broker=w.broker, started_at=w.started_at, last_seen_at=w.last_seen_at,
                                    slots=w.slots) for w in repo.workers_seen(s, live_within_s(settings.reaper_interval_s))]
            running = repo.running_count(s)
            waiting, oldest = repo.waiting(s, utcnow() - dt.timedelta(seconds=settings.stall_after_s))
        database, workers = "ok", seen  # plain copies: a commit that fails after the reads expires the rows
        slots = sum(w.slots or 1 for w in workers)
        queue = {"running": running, "slots": slots, "waiting_over_stall_after_s": waiting}
        if waiting:
            for_s = (utcnow() - oldest).total_seconds() if oldest else settings.stall_after_s
            if not workers:
                reasons.append(f"{waiting} job(s) queued for up to {for_s:.0f} s and no worker is connected to the "
                               "broker")
            elif slots > running:
                reasons.append(f"{waiting} job(s) queued for up to {for_s:.0f} s while {slots - running} of {slots} "
                               f"worker slot(s) sit idle (stalled; GAITMEND_STALL_AFTER_S={settings.stall_after_s:g})")
    except Exception as e:  # noqa: BLE001  (reported, not raised)
        database = safe_message(e)
        reasons.append(f"database: {database}")
    ok, broker = broker_ok(settings)
    if not ok:
        broker = safe_message(Exception(broker)).removeprefix("Exception: ")
        reasons.append(f"broker: {broker}")
    free = free_bytes(settings.data_dir)
    low = free is not None and free < settings.min_free_mb * 1024 * 1024
    disk = {"path": str(settings.data_dir.resolve()), "free_bytes": free, "min_free_bytes":
            settings.min_free_mb * 1024 * 1024, "low": low}
    if low:
        reasons.append(f"disk: {human(free)} free in the data folder {settings.data_dir.resolve()} "
                       f"(GAITMEND_MIN_FREE_MB={settings.min_free_mb})")
    return {"status": "degraded" if reasons else "ok", "reasons": reasons, "database": database, "broker": broker,
            "workers": workers, "disk": disk, "queue": queue}

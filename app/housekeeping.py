"""The reaper loop, run by `gaitmend serve` and by every worker's main process (reaping is
idempotent, so several at once are fine). Workers also report themselves as seen."""

from __future__ import annotations

import logging
import threading

from app.dispatch import dispatch_pending
from app.settings import Settings
from app.store import repo
from app.store.db import session_scope

log = logging.getLogger("gaitmend.housekeeping")


class Housekeeper:
    def __init__(self, settings: Settings, worker_name: str | None = None):
        self.settings = settings
        self.worker_name = worker_name
        self.stopped = threading.Event()

    def tick(self) -> None:
        if self.worker_name:
            with session_scope(self.settings.db_url) as s:
                repo.worker_seen(s, self.worker_name, self.settings.broker_url)
        dispatch_pending(self.settings)

    def loop(self) -> None:
        while not self.stopped.is_set():
            try:
                self.tick()
            except Exception:  # the database or broker may be briefly away; keep going
                log.exception("housekeeping pass failed")
            self.stopped.wait(self.settings.reaper_interval_s)

    def stop(self) -> None:
        self.stopped.set()

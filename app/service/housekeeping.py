"""The reaper loop, run by `gaitmend serve` and by every worker's main process (reaping is
idempotent, so several at once are fine). Workers also report themselves as seen."""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable

from app.service.dispatch import dispatch_pending
from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope

log = logging.getLogger("gaitmend.housekeeping")


class _ForkGuard:
    """Forks wait for a housekeeping pass to end.

    The worker's main process forks its pool processes while the housekeeper thread runs.
    A child forked while that thread is inside SQLite (or holds kombu's producer lock)
    inherits the lock held forever and hangs on its first query, taking a pool slot and the
    job it was given with it. Measured: a thread writing SQLite while the main thread forks
    300 children that each open the database hangs 43 of them; a real Housekeeper ticking
    beside 40 forks hung 5 without this guard and none with it (tests/workers/
    test_fork_guard.py). A pass is a few
    milliseconds; a fork waits at most `WAIT_S` for it (a database that is away makes the
    pass slow; the fork then goes ahead, as it did before)."""

    WAIT_S = 30.0

    def __init__(self):
        self.lock = threading.Lock()
        self._held_for_fork = False

    def before_fork(self) -> None:
        self._held_for_fork = self.lock.acquire(timeout=self.WAIT_S)

    def after_fork(self) -> None:  # parent and child alike: the forking thread holds it
        if self._held_for_fork:
            self._held_for_fork = False
            self.lock.release()


_fork_guard = _ForkGuard()
os.register_at_fork(before=_fork_guard.before_fork, after_in_parent=_fork_guard.after_fork,
                    after_in_child=_fork_guard.after_fork)


class Housekeeper:
    """`live`: whether this worker takes jobs now (its consumer is connected, it is not
    stopping); the worker is reported as seen only then, and forgotten otherwise.
    Every MAINTENANCE_S it also runs the retention sweep (app/store/space.py)."""

    MAINTENANCE_S = 60.0

    def __init__(self, settings: Settings, worker_name: str | None = None, live: Callable[[], bool] | None = None,
                 slots: int = 1):
        self.settings = settings
        self.worker_name = worker_name
        self.live = live or (lambda: True)
        self.slots = slots
        self.stopped = threading.Event()
        self._reported = False
        self._next_sweep = time.monotonic()

    def tick(self) -> None:
        with _fork_guard.lock:
            self._tick()

    def _tick(self) -> None:
        if self.worker_name:
            with session_scope(self.settings.db_url) as s:
                if self.live():
                    repo.worker_seen(s, self.worker_name, self.settings.broker_url, self.slots)
                    self._reported = True
                elif self._reported:
                    repo.worker_gone(s, self.worker_name)
                    self._reported = False
        dispatch_pending(self.settings)
        if time.monotonic() >= self._next_sweep:
            self._next_sweep = time.monotonic() + self.MAINTENANCE_S
            from app.store.space import sweep

            sweep(self.settings)

    def loop(self) -> None:
        while not self.stopped.is_set():
            try:
                self.tick()
            except Exception as e:  # the database or broker may be briefly away; keep going
                from app.store.errors import safe_message, transient

                if transient(e) is not None:
                    log.warning("housekeeping pass failed: %s", safe_message(e))
                else:
                    log.exception("housekeeping pass failed")
            self.stopped.wait(self.settings.reaper_interval_s)

    def stop(self) -> None:
        self.stopped.set()

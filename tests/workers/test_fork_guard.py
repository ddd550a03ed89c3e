"""A worker's main process forks pool processes while its housekeeper thread uses SQLite.
Without the fork guard (app/service/housekeeping.py) a child forked mid-query inherits SQLite's
lock held and hangs on its first query; with it none does. The CI failure this came from:
a pool process replaced after a kill never claimed its job (tests/workers/
test_worker_jobs.py, 'attempt 3 running' timed out)."""

from __future__ import annotations

import os
import signal
import threading
import time

from service_support import deployment, migrated
from sqlalchemy import text

from app.service.housekeeping import Housekeeper
from app.store.db import session_scope

FORKS = 40


def _child(url: str) -> None:
    try:
        with session_scope(url) as s:
            s.execute(text("select count(*) from jobs")).scalar()
        os._exit(0)
    except BaseException:
        os._exit(3)


def test_pool_processes_forked_during_housekeeping_passes_never_hang(tmp_path):
    settings = migrated(deployment(tmp_path, reaper_interval_s=0.001))
    keeper = Housekeeper(settings, worker_name="fork-test")
    ticks = 0

    def loop():
        nonlocal ticks
        while not keeper.stopped.is_set():
            keeper.tick()
            ticks += 1
            # a real housekeeper waits between passes; back to back, this thread retakes the
            # guard's (unfair) lock the instant it lets it go and a fork waits seconds for it
            time.sleep(0.0005)

    t = threading.Thread(target=loop, daemon=True)
    t.start()
    hung, failed = 0, 0
    try:
        for _ in range(FORKS):
            pid = os.fork()
            if pid == 0:
                _child(settings.db_url)
            end = time.monotonic() + 10
            while True:
                done, status = os.waitpid(pid, os.WNOHANG)
                if done:
                    failed += os.waitstatus_to_exitcode(status) != 0
                    break
                if time.monotonic() > end:
                    hung += 1
                    os.kill(pid, signal.SIGKILL)
                    os.waitpid(pid, 0)
                    break
                time.sleep(0.002)
    finally:
        keeper.stop()
        t.join(10)
    assert ticks > FORKS / 2, ticks  # the passes really ran beside the forks
    assert (hung, failed) == (0, 0), f"{hung} of {FORKS} children hung, {failed} failed"

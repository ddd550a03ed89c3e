"""The worker's hold on its broker connection, and its stop.

Liveness. A worker counts as live (in /api/health and in the dispatch window) only while
its consumer is connected: ``CONSUMER.connected`` is set and cleared by a consumer
bootstep (``ConsumerGuard``) that Celery starts after each (re)connection and stops when
the connection is lost; the housekeeper reports the worker only while it is set.

The silent stall (issue 27). With acks_late, a job that finishes while Redis is down
cannot be acknowledged: kombu logs "Couldn't ack" and keeps the message's delivery tag
in its prefetch count for ever (kombu.transport.redis.QoS.ack raises before forgetting
it), so the consumer never asks the broker for another message, never notices that the
connection is gone, and never reconnects. The guard checks every second, inside the
event loop, for a consumer that holds no job yet cannot consume; twice in a row, it
raises a connection error there, which makes Celery drop the connection and reconnect
(a fresh channel, a fresh prefetch count). The unacknowledged message may come back;
claiming a finished job again is harmless.

Reconnecting. kombu retries a lost connection after 2, 4, ... up to 30 s; the worker's
connection class retries every second, then at most every RECONNECT_MAX_S, so the queue
moves within seconds of the broker's return, and without a limit on the number of tries.

Stopping (SIGTERM). ``on_shutdown`` marks the jobs of this worker's pool processes as
interrupted (so a SIGKILL that follows costs them no attempt), forwards SIGTERM to the
pool processes running them (Docker signals PID 1 only; an idle pool process is left to
Celery's own warm shutdown: one killed by a signal costs billiard a 5 s wait), and
removes the worker from the live ones.
Each pool process then hands its job back at the next generation boundary, or after
GAITMEND_STOP_GRACE_S from its last checkpoint (app/service/runner.py). Once this worker
holds no job (none running, none prefetched: every message acknowledged), it exits at
once: Celery's own warm shutdown takes another 5-7 s on two busy cores, and Docker
kills at 10 s.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import threading
import time

from celery import bootsteps
from kombu import Connection

log = logging.getLogger("gaitmend.worker")

CHECK_EVERY_S = 1.0
STALL_CHECKS = 2
RECONNECT_MAX_S = 3.0


class _ConsumerState:
    def __init__(self):
        self.connected = False
        self.stopping = False
        self.reconnects = 0
        self.stalls = 0


CONSUMER = _ConsumerState()


class ReconnectingConnection(Connection):
    """A broker connection that retries every second at first and at most every
    RECONNECT_MAX_S (kombu's default backs off to 30 s)."""

    def ensure_connection(self, errback=None, max_retries=None, interval_start=1.0, interval_step=1.0,
                          interval_max=RECONNECT_MAX_S, **kwargs):
        return super().ensure_connection(errback, max_retries, interval_start, interval_step, interval_max, **kwargs)


class ConsumerGuard(bootsteps.StartStopStep):
    """Tracks whether the consumer is connected and breaks the post-ack-failure stall."""

    requires = ("celery.worker.consumer.tasks:Tasks",)

    def __init__(self, c, **kwargs):
        super().__init__(c, **kwargs)
        self.tref = None
        self.suspect = 0

    def start(self, c):
        if CONSUMER.connected is False and CONSUMER.reconnects:
            log.warning("consumer connected to the broker again")
        CONSUMER.connected = True
        CONSUMER.reconnects += 1
        self.suspect = 0
        if c.timer is not None:
            self.tref = c.timer.call_repeatedly(CHECK_EVERY_S, self.check, (c,), priority=10)

    def stop(self, c):
        if CONSUMER.connected and not CONSUMER.stopping:
            log.warning("consumer lost its broker connection; this worker does not count as live until it reconnects")
        CONSUMER.connected = False
        if self.tref is not None:
            self.tref.cancel()
            self.tref = None

    def shutdown(self, c):
        self.stop(c)

    def check(self, c):
        """Runs in the event loop: a raise here reaches Consumer.start, which reconnects."""
        if CONSUMER.stopping:
            return
        consumer = getattr(c, "task_consumer", None)
        qos = getattr(getattr(consumer, "channel", None), "qos", None)
        if qos is None or not hasattr(qos, "can_consume"):
            return
        from celery.worker import state

        if not state.reserved_requests and not qos.can_consume():
            self.suspect += 1
            if self.suspect >= STALL_CHECKS:
                self.suspect = 0
                CONSUMER.stalls += 1
                CONSUMER.connected = False
                log.warning("consumer holds no job but cannot take one (an acknowledgement failed while the broker "
                            "was away): reconnecting to the broker")
                raise c.connection.connection_errors[0]("consumer stalled after a failed acknowledgement")
        else:
            self.suspect = 0


def pool_children() -> list[int]:
    """PIDs of this process's children (the prefork pool)."""
    me = os.getpid()
    out = []
    for name in os.listdir("/proc") if os.path.isdir("/proc") else ():
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read().decode(errors="replace")
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if ppid == me:
            out.append(int(name))
    if not out:  # no /proc: billiard's own list
        from billiard import process

        out = [p.pid for p in process.active_children() if p.pid]
    return out


def on_shutdown(settings, worker_name: str) -> None:
    """The worker was asked to stop (runs in a thread, not in the signal handler)."""
    CONSUMER.stopping = True
    children = pool_children()
    host = socket.gethostname()
    busy = children  # unknown: tell them all
    try:
        from app.store import repo
        from app.store.db import session_scope
        from app.store.errors import retry

        def mark():
            with session_scope(settings.db_url) as s:
                return repo.interrupt_workers(s, [f"{host}:{pid}" for pid in children])

        found = retry(mark, until=time.monotonic() + 3.0, what="marking interrupted jobs")
        busy = [int(w.rsplit(":", 1)[1]) for w in found.values()]
        if found:
            log.warning("stopping: handing back %d running job(s) %s at their next generation boundary "
                        "(at most %.0f s)", len(found), list(found), settings.stop_grace_s)
    except Exception as e:  # noqa: BLE001  (the database is away: the pool processes still hand back)
        log.warning("stopping: could not mark running jobs as interrupted: %s", e)
    for pid in busy:
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    try:
        from app.store import repo
        from app.store.db import session_scope

        with session_scope(settings.db_url) as s:
            repo.worker_gone(s, worker_name)
    except Exception:  # noqa: BLE001
        pass
    exit_when_idle(settings.stop_grace_s + EXIT_MARGIN_S)


EXIT_MARGIN_S = 5.0


def exit_when_idle(within_s: float) -> None:
    """End the process as soon as it holds no job (Celery's state: no request reserved,
    i.e. every message received was acknowledged or rejected), after a moment for Celery to
    finish on its own; give up after `within_s` (Celery's shutdown then runs its course)."""
    from celery.worker import state

    end = time.monotonic() + within_s
    while time.monotonic() < end:
        if not state.reserved_requests:
            time.sleep(0.3)  # the acknowledgement of the last result, the pool's own exit
            if not state.reserved_requests:
                log.warning("stopping: no job held; exiting")
                logging.shutdown()
                os._exit(0)
        time.sleep(0.1)


def start_shutdown_thread(settings, worker_name: str) -> None:
    threading.Thread(target=on_shutdown, args=(settings, worker_name), name="stopping", daemon=True).start()

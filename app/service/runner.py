"""Running one job in a worker: claim it with a lease, give the kind a database-backed run
context, write the bundle, finish. The Celery task (workers/tasks.py) only calls run_job.

Faults (docs/faults.md):
- every write of the life cycle (claim, lease renewal, progress, checkpoint, finish)
  retries a dropped connection with backoff for as long as the lease lasts; the lease
  token still fences a worker whose lease another took (the lease and fencing protocol:
  app/store/repo/leases.py). A job fails only for its own
  errors (with a message free of SQL, parameters and tokens) or after its attempts;
- SIGTERM (``request_stop``): the job is handed back at the next generation boundary
  (its checkpoint is saved there) without spending an attempt, or, still inside a
  generation after GAITMEND_STOP_GRACE_S, from its last checkpoint, and the process exits;
- a full disk: a bundle or checkpoint that cannot be written for space waits for space
  (GAITMEND_STORAGE_WAIT_S), keeping the lease, then fails naming the folder and the free space.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import socket
import threading
import time
import uuid
from pathlib import Path
from typing import Any, Callable, TypeVar

from app.jobs.base import Cancelled, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec
from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope
from app.store.errors import StoreUnavailable, retry, safe_message, transient
from app.store.space import describe, free_bytes

log = logging.getLogger("gaitmend.runner")
T = TypeVar("T")


class LeaseLost(Exception):
    """Another worker owns the job now (our lease expired and the reaper requeued it)."""


class JobTimeout(Exception):
    pass


class Handoff(BaseException):
    """This worker is stopping: the job goes back to the queue. A BaseException, so that a
    kind's own ``except Exception`` cannot swallow it."""


# -- stopping --------------------------------------------------------------------------------------

STOP = threading.Event()  # this process was asked to stop (SIGTERM)
_stop_at: list[float] = []
_running: list["DbRunContext"] = []  # the job this process runs (one: a pool process runs one job)
_signalled = [False]  # set by the SIGTERM handler, which must take no lock; the heartbeat acts on it
_busy = [False]  # inside run_job


def request_stop() -> None:
    """Hand the running job back and take no other (idempotent). Not for a signal handler."""
    if not _stop_at:
        _stop_at.append(time.monotonic())
    STOP.set()
    for ctx in list(_running):
        ctx.wake.set()


def stopping() -> bool:
    return STOP.is_set() or _signalled[0]


def stop_deadline(settings: Settings) -> float | None:
    return _stop_at[0] + settings.stop_grace_s if _stop_at else None


_installed_in: list[int] = []


def install_stop_handler() -> None:
    """In a pool process, from its main thread (the Celery task does it before each job:
    billiard replaces SIGTERM handlers installed before its worker loop starts).
    SIGTERM while a job runs hands the job back (see the module doc); while idle, the
    handler in place before (billiard's clean exit) runs as before."""
    if _installed_in == [os.getpid()]:
        return
    before = signal.getsignal(signal.SIGTERM)

    def on_term(signum, frame):
        if _busy[0]:  # no lock here: the main thread may hold any; the heartbeat polls this
            if not _stop_at:
                _stop_at.append(time.monotonic())
            _signalled[0] = True
            return
        if callable(before):
            before(signum, frame)
        else:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)

    signal.signal(signal.SIGTERM, on_term)
    _installed_in[:] = [os.getpid()]


def worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


# -- the run context ------------------------------------------------------------------------------

class DbRunContext:
    """What a job kind sees: progress, checkpoints and the cancel flag, all in the jobs
    table and fenced by the lease; a heartbeat thread keeps the lease while the job runs
    (a generation, the bundle, the finish) and enforces the stop deadline."""

    def __init__(self, settings: Settings, claim: repo.Claim):
        self.settings = settings
        self.claim = claim
        self.artifact_dir = Path(settings.artifact_dir) / claim.job_id
        self.artifact_dir.mkdir(parents=True, exist_ok=True)
        self.lost = threading.Event()
        self.wake = threading.Event()
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._renewed = time.monotonic()  # when the lease was last known to be extended
        self._state = "running"  # -> "finishing" (the kind returned) or "handed-back"
        self._state_lock = threading.Lock()
        self._marked = False
        self._beat = threading.Thread(target=self._heartbeat, name=f"lease-{claim.job_id[:8]}", daemon=True)

    # -- lease ----------------------------------------------------------------------------
    def __enter__(self):
        _running.append(self)
        self._beat.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self.wake.set()
        self._beat.join()
        if self in _running:
            _running.remove(self)
        try:  # no empty artifact folder left behind
            self.artifact_dir.rmdir()
        except OSError:
            pass
        return False

    def _lease_until(self) -> float:
        """Retries of a dropped connection stop where the lease would have run out."""
        return self._renewed + self.settings.lease_s

    def _tx(self, what: str, fn: Callable[[Any], T], readonly: bool = False, space_wait: bool = True,
            abandonable: bool = True) -> T:
        def once():
            with session_scope(self.settings.db_url, readonly=readonly) as s:
                return fn(s)

        until = self._lease_until()
        space_until = max(until, time.monotonic() + self.settings.storage_wait_s) if space_wait else until
        return retry(once, until=until, space_until=space_until, what=f"job {self.claim.job_id}: {what}",
                     should_stop=self._should_abandon if abandonable else None)

    def _should_abandon(self) -> bool:
        return self.lost.is_set() or self._state == "handed-back" or (
            self._stop.is_set() and threading.current_thread() is self._beat)

    def _heartbeat(self) -> None:
        every = self.settings.lease_s / 3
        next_beat = time.monotonic() + every
        while not self._stop.is_set():
            deadline = stop_deadline(self.settings)
            wait = next_beat - time.monotonic()
            if deadline is not None:
                wait = min(wait, deadline - time.monotonic())
            self.wake.wait(min(max(wait, 0.0), 0.25))
            self.wake.clear()
            if self._stop.is_set():
                return
            if _signalled[0] and not STOP.is_set():
                request_stop()
            if STOP.is_set() and not self._marked:
                self._marked = True
                self._quietly("mark interrupted", lambda s: repo.mark_interrupted(s, self.claim))
            deadline = stop_deadline(self.settings)
            if deadline is not None and time.monotonic() >= deadline and self._state == "running":
                self._hand_back_and_exit()
                return
            if time.monotonic() < next_beat:
                continue
            try:
                ok = self._tx("lease renewal", lambda s: repo.heartbeat(s, self.claim.job_id, self.claim.lease_token,
                                                                         self.settings.lease_s), space_wait=False)
            except StoreUnavailable:  # past the lease: keep trying, the reaper may not have run
                next_beat = time.monotonic() + min(every, 1.0)
                continue
            except Exception:  # noqa: BLE001  (not a store error: a bug; log and try again next beat)
                log.exception("heartbeat failed for job %s", self.claim.job_id)
                next_beat = time.monotonic() + every
                continue
            if not ok:
                self.lost.set()
                return
            self._renewed = time.monotonic()
            next_beat = self._renewed + every

    def _quietly(self, what: str, fn) -> Any:
        """A write that must not be abandoned half-way (marking the stop, handing back)."""
        try:
            return self._tx(what, fn, space_wait=False, abandonable=False)
        except Exception as e:  # noqa: BLE001
            log.warning("job %s: %s failed: %s", self.claim.job_id, what, safe_message(e))
            return None

    def _hand_back_and_exit(self) -> None:
        """The stop deadline passed inside a generation: hand the job back from its last
        checkpoint, send it, and end this process (the generation in flight is dropped)."""
        with self._state_lock:
            if self._state != "running":
                return
            self._state = "handed-back"
        released = self._quietly("hand back", lambda s: repo.release(s, self.claim))
        if released:
            _send(self.settings, [self.claim.job_id])
        log.warning("job %s: still inside a generation %.1f s after the stop request; handed back from its last "
                    "checkpoint (%s); exiting", self.claim.job_id, self.settings.stop_grace_s,
                    "released" if released else "left to the reaper")
        logging.shutdown()
        os._exit(0)

    def _check_lease(self, ok: bool) -> None:
        if not ok:
            self.lost.set()
        if self.lost.is_set() or self._state == "handed-back":
            raise LeaseLost(self.claim.job_id)

    def _note_renewed(self) -> None:
        self._renewed = time.monotonic()

    # -- RunContext -------------------------------------------------------------------------
    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        info = json.loads(dumps(info))
        ok = self._tx("progress", lambda s: repo.record_progress(s, self.claim, done, total, info,
                                                                 self.settings.lease_s))
        if ok:
            self._note_renewed()
        self._check_lease(ok)

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        data = dumps(state)
        ok = self._tx("checkpoint", lambda s: repo.save_checkpoint(s, self.claim, data))
        self._check_lease(ok)

    def load_checkpoint(self) -> dict[str, Any] | None:
        data = self._tx("load checkpoint", lambda s: repo.load_checkpoint(s, self.claim.job_id), readonly=True)
        return None if data is None else json.loads(data)

    def is_cancelled(self) -> bool:
        """Checked at every generation boundary (the previous generation's checkpoint is
        saved): also where a stopping worker hands the job back."""
        self._check_lease(True)
        if time.monotonic() - self._t0 > self.settings.max_job_s:
            raise JobTimeout(f"the job ran longer than max_job_s={self.settings.max_job_s} s")
        cancel, interrupted = self._tx("read flags", lambda s: repo.job_flags(s, self.claim.job_id), readonly=True)
        if (interrupted or _signalled[0]) and not STOP.is_set():  # SIGTERM here, or to the worker's main process
            request_stop()
        if STOP.is_set() and not cancel:
            raise Handoff()
        return cancel

    def load_robot(self, robot_id: str):
        """The uploaded robot the job names, as stored (sanitised) under the data folder, if it
        is the job owner's (POST /api/jobs checks it too; a job reaching the queue another way,
        a study's point say, still runs only on its owner's robots); a robot a queued or
        running job names cannot be deleted."""
        from app.store import robots as robot_store

        def load(s):
            try:
                owner = repo.get_job(s, self.claim.job_id).owner
                return robot_store.load_robot(s, self.settings.data_dir, robot_id, owner)
            except repo.NotFound:
                return None

        robot = self._tx("load robot", load, readonly=True)
        if robot is None:
            raise SpecError([{"field": "robot", "message": f"no uploaded robot {robot_id!r}"}])
        return robot

    # -- the end ------------------------------------------------------------------------------
    def finishing(self) -> None:
        """The kind returned: from now on the stop deadline lets the job finish."""
        with self._state_lock:
            if self._state == "handed-back":
                raise LeaseLost(self.claim.job_id)
            self._state = "finishing"

    def hand_back(self, why: str) -> str:
        with self._state_lock:
            if self._state == "handed-back":
                return "handed-back"
            self._state = "handed-back"
        released = self._quietly("hand back", lambda s: repo.release(s, self.claim))
        if released:
            _send(self.settings, [self.claim.job_id])
            log.info("job %s handed back (%s); it resumes from its last checkpoint without spending an attempt",
                     self.claim.job_id, why)
            return "handed-back"
        log.warning("job %s: could not hand it back (%s); the reaper requeues it when its lease ends",
                    self.claim.job_id, why)
        return "lease-lost"

    def abandon(self, e: BaseException) -> str:
        """The store stayed unreachable longer than the lease: not the job's fault. The job
        goes back to the queue (the attempt is spent: an outage cannot loop a job for
        ever), from its last checkpoint."""
        log.warning("job %s: the database stayed unavailable (%s); putting the job back in the queue",
                    self.claim.job_id, safe_message(e))
        requeued = False
        try:
            requeued = retry(lambda: _once(self.settings, lambda s: repo.release(s, self.claim, refund=False)),
                             until=time.monotonic() + self.settings.lease_s, what=f"job {self.claim.job_id}: requeue")
        except Exception as e2:  # noqa: BLE001
            log.warning("job %s: could not requeue it (%s); the reaper does when its lease ends", self.claim.job_id,
                        safe_message(e2))
        if requeued:
            _send(self.settings, [self.claim.job_id])
        return "store-unavailable"

    def write_bundle(self, write: Callable[[], Path], folder: Path) -> Path:
        """The bundle, waiting for space when the disk is full (the lease is kept). A new try
        waits until the free space grew (or SPACE_RECHECK_S passed): a try costs the plots."""
        until = time.monotonic() + self.settings.storage_wait_s
        t0, announced = time.monotonic(), False
        while True:
            try:
                return write()
            except OSError as e:
                if transient(e) != "space":
                    raise
                free_then = free_bytes(folder) or 0
                if not announced:
                    announced = True
                    log.warning("job %s: no space left writing its bundle to %s; waiting up to %.0f s for space",
                                self.claim.job_id, describe(folder), self.settings.storage_wait_s)
                retry_at = time.monotonic() + SPACE_RECHECK_S
                while True:
                    if stopping():
                        raise Handoff() from None
                    self._check_lease(True)
                    if time.monotonic() >= until:
                        raise NoSpace(f"no space left on the device writing the bundle to {describe(folder)}; "
                                      f"waited {time.monotonic() - t0:.0f} s (GAITMEND_STORAGE_WAIT_S) for space; "
                                      "free some (e.g. delete old jobs) and retry the job") from None
                    free = free_bytes(folder) or 0
                    if free > free_then + 256 * 1024 or time.monotonic() >= retry_at:
                        break
                    time.sleep(0.5)

    def finish(self, status: str, **fields) -> bool:
        def do(s):
            ok = repo.finish(s, self.claim, status, **fields)
            # A retry after a commit whose answer was lost finds the job already finished.
            return ok or repo.finished_as(s, self.claim.job_id) == status

        return self._tx("finish", do)


SPACE_RECHECK_S = 15.0


class NoSpace(Exception):
    """The disk stayed full for GAITMEND_STORAGE_WAIT_S: the job fails saying where and how full."""


def _once(settings: Settings, fn):
    with session_scope(settings.db_url) as s:
        return fn(s)


def _send(settings: Settings, ids: list[str]) -> None:
    """Send these queued jobs again now (their message is consumed or was never sent)."""
    from app.service.dispatch import send

    try:
        with session_scope(settings.db_url) as s:
            repo.mark_dispatched(s, ids)
        send(settings, ids)
    except Exception as e:  # noqa: BLE001  (the housekeeper sends it on its next pass)
        log.warning("could not send %s again: %s", ids, safe_message(e))


def bundle_path(settings: Settings, job_id: str) -> Path:
    return Path(settings.bundle_dir) / f"{job_id}.zip"


def run_job(settings: Settings, job_id: str) -> str:
    """Claim and run one job; returns the state it was left in, or 'skipped' (nothing to
    run), 'handed-back' (this worker is stopping), 'store-unavailable' or 'lease-lost'."""
    _busy[0] = True
    try:
        return _run_job(settings, job_id)
    finally:
        _busy[0] = False


def _run_job(settings: Settings, job_id: str) -> str:
    from app.results.bundle import write_bundle

    if stopping():  # this worker is stopping: leave the job to another
        _send(settings, [job_id])
        return "handed-back"
    token = uuid.uuid4().hex
    try:
        claim = retry(lambda: _once(settings, lambda s: repo.claim(s, job_id, worker=worker_name(),
                                                                   lease_s=settings.lease_s, token=token)),
                      until=time.monotonic() + settings.lease_s, what=f"job {job_id}: claim",
                      space_until=time.monotonic() + settings.storage_wait_s, should_stop=stopping)
    except StoreUnavailable as e:  # its message is gone; the housekeeper sends the job again
        log.warning("job %s: could not claim it: %s", job_id, safe_message(e))
        return "store-unavailable"
    if claim is None:
        return "skipped"
    log.info("job %s attempt %d claimed", job_id, claim.attempt)
    status, fields = "failed", {}
    with DbRunContext(settings, claim) as ctx:
        try:
            spec = parse_spec(claim.spec)
            kind = get_kind(spec.kind)
            result = kind.run(spec, ctx)
            ctx.finishing()
            if ctx.lost.is_set():
                raise LeaseLost(job_id)
            path = ctx.write_bundle(lambda: write_bundle(bundle_path(settings, job_id), job_id, spec, result),
                                    Path(settings.bundle_dir))
            status = "succeeded"
            fields = {"summary": json.loads(dumps(result.summary)), "bundle_path": str(path),
                      "history_rows": json.loads(dumps(result.history))}
        except Cancelled:
            status = "cancelled"
        except Handoff:
            return ctx.hand_back("the worker is stopping")
        except LeaseLost:
            log.warning("job %s: lease lost, leaving it to its new owner", job_id)
            return "lease-lost"
        except (SpecError, JobTimeout, NoSpace) as e:
            fields = {"error": str(e)}
        except Exception as e:  # noqa: BLE001
            if transient(e) is not None:  # the store, not the job: StoreUnavailable or a raw disconnect
                return ctx.abandon(e)
            # a bug or bad numbers: deterministic, so no retry
            log.exception("job %s failed", job_id)
            fields = {"error": safe_message(e, keep={job_id})}
        try:
            ok = ctx.finish(status, **fields)
        except Exception as e:  # noqa: BLE001
            if transient(e) is None:
                raise
            return ctx.abandon(e)
    if not ok:
        return "lease-lost"
    return status


"""Running one job in a worker: claim it with a lease, give the kind a database-backed run
context, write the bundle, finish. The Celery task (workers/tasks.py) only calls run_job."""

from __future__ import annotations

import json
import logging
import os
import socket
import threading
import time
import traceback
from pathlib import Path
from typing import Any

from app.jobs.base import Cancelled, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec
from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope

log = logging.getLogger("gaitmend.runner")


class LeaseLost(Exception):
    """Another worker owns the job now (our lease expired and the reaper requeued it)."""


class JobTimeout(Exception):
    pass


def worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


class DbRunContext:
    """What a job kind sees: progress, checkpoints and the cancel flag, all in the jobs
    table and fenced by the lease; a heartbeat thread keeps the lease while a generation runs."""

    def __init__(self, settings: Settings, claim: repo.Claim):
        self.settings = settings
        self.claim = claim
        self.artifact_dir = Path(settings.artifact_dir) / claim.job_id
        self.artifact_dir.mkdir(parents=True, exist_ok=True)
        self.lost = threading.Event()
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._beat = threading.Thread(target=self._heartbeat, name=f"lease-{claim.job_id[:8]}", daemon=True)

    # -- lease ----------------------------------------------------------------------------
    def __enter__(self):
        self._beat.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._beat.join()
        return False

    def _heartbeat(self) -> None:
        every = self.settings.lease_s / 3
        while not self._stop.wait(every):
            try:
                with session_scope(self.settings.db_url) as s:
                    ok = repo.heartbeat(s, self.claim.job_id, self.claim.lease_token, self.settings.lease_s)
            except Exception:  # a database hiccup: try again next beat, the lease has slack
                log.exception("heartbeat failed for job %s", self.claim.job_id)
                continue
            if not ok:
                self.lost.set()
                return

    def _check_lease(self, ok: bool) -> None:
        if not ok:
            self.lost.set()
        if self.lost.is_set():
            raise LeaseLost(self.claim.job_id)

    # -- RunContext -------------------------------------------------------------------------
    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        info = json.loads(dumps(info))
        with session_scope(self.settings.db_url) as s:
            ok = repo.record_progress(s, self.claim, done, total, info, self.settings.lease_s)
        self._check_lease(ok)

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        data = dumps(state)
        with session_scope(self.settings.db_url) as s:
            ok = repo.save_checkpoint(s, self.claim, data)
        self._check_lease(ok)

    def load_checkpoint(self) -> dict[str, Any] | None:
        with session_scope(self.settings.db_url, readonly=True) as s:
            data = repo.load_checkpoint(s, self.claim.job_id)
        return None if data is None else json.loads(data)

    def is_cancelled(self) -> bool:
        self._check_lease(True)
        if time.monotonic() - self._t0 > self.settings.max_job_s:
            raise JobTimeout(f"the job ran longer than max_job_s={self.settings.max_job_s} s")
        with session_scope(self.settings.db_url, readonly=True) as s:
            return repo.cancel_requested(s, self.claim.job_id)


def bundle_path(settings: Settings, job_id: str) -> Path:
    return Path(settings.bundle_dir) / f"{job_id}.zip"


def run_job(settings: Settings, job_id: str) -> str:
    """Claim and run one job; returns the state it was left in (or 'skipped')."""
    from app.results.bundle import write_bundle

    with session_scope(settings.db_url) as s:
        claim = repo.claim(s, job_id, worker=worker_name(), lease_s=settings.lease_s)
    if claim is None:
        return "skipped"
    log.info("job %s attempt %d claimed", job_id, claim.attempt)
    status, fields = "failed", {}
    try:
        with DbRunContext(settings, claim) as ctx:
            try:
                spec = parse_spec(claim.spec)
                kind = get_kind(spec.kind)
                result = kind.run(spec, ctx)
                if ctx.lost.is_set():
                    raise LeaseLost(job_id)
                path = write_bundle(bundle_path(settings, job_id), job_id, spec, result)
                status = "succeeded"
                fields = {"summary": json.loads(dumps(result.summary)), "bundle_path": str(path),
                          "history_rows": json.loads(dumps(result.history))}
            except Cancelled:
                status = "cancelled"
            except (SpecError, JobTimeout) as e:
                fields = {"error": str(e)}
            except LeaseLost:
                raise
            except Exception as e:  # a bug or bad numbers: deterministic, so no retry
                log.exception("job %s failed", job_id)
                tb = traceback.format_exception_only(type(e), e)[-1].strip()
                fields = {"error": f"{tb}"}
    except LeaseLost:
        log.warning("job %s: lease lost, leaving it to its new owner", job_id)
        return "lease-lost"
    with session_scope(settings.db_url) as s:
        ok = repo.finish(s, claim, status, **fields)
    return status if ok else "lease-lost"

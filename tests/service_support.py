"""Helpers shared by tests/store, tests/api and tests/workers: settings for a temporary
deployment, worker and server processes, polling."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

from app.core.settings import Settings, load_settings
from app.store.db import session_scope
from app.store.migrate import upgrade
from app.store.models import Job

SMALL = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
         "search": {"population": 6, "generations": 3, "seed": 1}, "sim": {"duration_s": 2.0}}


def spec(generations: int = 3, population: int = 6, seed: int = 1, duration_s: float = 2.0) -> dict:
    return {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
            "search": {"population": population, "generations": generations, "seed": seed},
            "sim": {"duration_s": duration_s}}


def deployment(tmp_path: Path, database_url: str | None = None, broker: tuple[str, str] | None = None,
               **overrides) -> dict[str, str]:
    """GAITMEND_* variables of a throw-away deployment: short leases so tests see the reaper."""
    env = {
        "GAITMEND_DATA_DIR": str(tmp_path / "data"),
        "GAITMEND_QUEUE": f"q{uuid.uuid4().hex[:10]}",
        "GAITMEND_LEASE_S": "3",
        "GAITMEND_REAPER_INTERVAL_S": "0.5",
        "GAITMEND_POLL_INTERVAL_S": "0.1",
        "GAITMEND_REDISPATCH_AFTER_S": "60",
    }
    if database_url:
        env["GAITMEND_DATABASE_URL"] = database_url
    if broker:
        env["GAITMEND_BROKER_URL"], env["GAITMEND_REDIS_KEY_PREFIX"] = broker
    env.update({f"GAITMEND_{k.upper()}": str(v) for k, v in overrides.items()})
    return env


def settings_of(env: dict[str, str]) -> Settings:
    kw = {k.removeprefix("GAITMEND_").lower(): v for k, v in env.items()}
    s = load_settings(**kw)
    s.data_dir.mkdir(parents=True, exist_ok=True)
    return s


def migrated(env: dict[str, str]) -> Settings:
    s = settings_of(env)
    upgrade(s.db_url)
    return s


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def proc_env(env: dict[str, str]) -> dict[str, str]:
    base = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")}
    return base | env | {"PYTHONUNBUFFERED": "1", "COLUMNS": "240"}  # rich wraps messages at 80


ENTRY = "from app.cli import main; main()"  # `-m app.cli` would run a second copy of app.cli


class Proc:
    """A gaitmend process in its own process group (so kill -9 takes its children too)."""

    def __init__(self, args: list[str], env: dict[str, str], log: Path):
        self.log = log
        self._fh = open(log, "ab")
        self.p = subprocess.Popen([sys.executable, "-c", ENTRY, *args], env=proc_env(env),
                                  stdout=self._fh, stderr=subprocess.STDOUT, start_new_session=True)

    @property
    def pid(self) -> int:
        return self.p.pid

    def kill9(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.p.pid, signal.SIGKILL)
        self.p.wait(10)

    def stop(self) -> None:
        if self.p.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.p.pid, signal.SIGTERM)
            try:
                self.p.wait(15)
            except subprocess.TimeoutExpired:
                self.kill9()
        with contextlib.suppress(ProcessLookupError):  # stray pool children
            os.killpg(self.p.pid, signal.SIGKILL)
        self._fh.close()

    def tail(self, n: int = 40) -> str:
        return "\n".join(self.log.read_text(errors="replace").splitlines()[-n:])


def wait_for(pred, timeout: float, what: str, interval: float = 0.1, proc: Proc | None = None):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        v = pred()
        if v:
            return v
        time.sleep(interval)
    extra = f"\n--- log ---\n{proc.tail()}" if proc else ""
    raise AssertionError(f"timed out after {timeout} s waiting for {what}{extra}")


def job_row(settings: Settings, job_id: str) -> Job:
    from app.store import repo

    with session_scope(settings.db_url, readonly=True) as s:
        return repo.get_job(s, job_id)


def job_count(settings: Settings) -> int:
    from sqlalchemy import func, select

    with session_scope(settings.db_url, readonly=True) as s:
        return s.scalar(select(func.count()).select_from(Job))


def checkpoint_saves(settings: Settings, job_id: str) -> int:
    from app.store import repo

    with session_scope(settings.db_url, readonly=True) as s:
        return repo.checkpoint_saves(s, job_id)


def reference_result(spec_dict: dict) -> dict:
    """An uninterrupted run of the same spec, in this process."""
    from app.jobs.base import MemoryContext, dumps
    from app.jobs.registry import get_kind, parse_spec

    import tempfile

    sp = parse_spec(spec_dict)
    with tempfile.TemporaryDirectory() as tmp:
        res = get_kind(sp.kind).run(sp, MemoryContext(Path(tmp)))
    return json.loads(dumps(res.summary))


def reference_run(spec_dict: dict) -> tuple[dict, int]:
    """An uninterrupted run in this process: (summary, checkpoints it saved)."""
    from app.jobs.base import MemoryContext, dumps
    from app.jobs.registry import get_kind, parse_spec

    import tempfile

    class Counting(MemoryContext):
        saves = 0

        def save_checkpoint(self, state):
            self.saves += 1
            super().save_checkpoint(state)

    sp = parse_spec(spec_dict)
    with tempfile.TemporaryDirectory() as tmp:
        ctx = Counting(Path(tmp))
        res = get_kind(sp.kind).run(sp, ctx)
    return json.loads(dumps(res.summary)), ctx.saves


def comparable(summary: dict) -> dict:
    """A summary without its wall-clock timings."""
    return {k: v for k, v in summary.items() if k != "timing"} | {
        "evaluations": summary["timing"]["evaluations"], "sim_steps": summary["timing"]["sim_steps"]}

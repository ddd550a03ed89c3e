"""The store's side of the faults of issue 27, on SQLite and on PostgreSQL: what counts as
a transient error and what a user may read of one (a real terminated PostgreSQL backend),
messages that cannot be in the broker, study points fed within the owner's limit (a
300-point study driven to the end with the default limits), the health verdicts, and
the retention sweep. The real processes under the same faults: tests/faults/."""

from __future__ import annotations

import datetime as dt
import os
import time

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated
from sqlalchemy import select, text, update

from app.store import repo
from app.store.db import session_scope
from app.store.errors import safe_message, transient
from app.store.migrate import upgrade
from app.store.models import Job, JobCheckpoint, Worker, utcnow
from app.studies.fair import feed, select_fair, study_share

BASE = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
        "search": {"population": 4, "generations": 1, "seed": 0}, "sim": {"duration_s": 0.5}}


@pytest.fixture
def url(database_url):
    upgrade(database_url)
    return database_url


def new_job(url, owner="alice", **kw) -> str:
    with session_scope(url) as s:
        return repo.create_job(s, owner=owner, kind="recovery", robot="jethexa", spec={"kind": "recovery"},
                               evaluations_budget=8, max_attempts=3, **kw).id


def test_a_terminated_postgresql_backend_is_transient_and_its_message_holds_no_sql_or_token(pg_url):
    import psycopg

    from app.store.db import get_engine

    app_name = f"gmfault{os.getpid()}"
    url = pg_url.replace("postgresql://", "postgresql+psycopg://") + f"&application_name={app_name}"
    upgrade(url)
    jid = new_job(url)
    token = "c0ffee" * 5 + "ab"
    engine, _ = get_engine(url)
    with engine.connect() as conn:
        conn.execute(text("SELECT 1"))
        with psycopg.connect(pg_url.split("?")[0], autocommit=True) as killer:
            n = killer.execute("SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity WHERE application_name = %s",
                               (app_name,)).fetchone()[0]
        assert n >= 1
        with pytest.raises(Exception) as e:
            conn.execute(update(Job).where(Job.id == jid, Job.lease_token == token).values(worker="w"))
    assert transient(e.value) == "connection"
    raw = str(e.value)
    assert "UPDATE jobs" in raw and token in raw  # what SQLAlchemy would have shown the user
    msg = safe_message(e.value)
    assert "UPDATE" not in msg and "[SQL" not in msg and token not in msg and "parameters" not in msg, msg
    assert msg.split(":")[0] in ("AdminShutdown", "OperationalError"), msg
    with session_scope(url, readonly=True) as s:  # the pool recovers by itself
        assert repo.get_job(s, jid).id == jid


def test_transient_errors_are_told_apart_from_the_jobs_own(tmp_path):
    import errno
    import sqlite3

    from sqlalchemy.exc import IntegrityError, OperationalError

    assert transient(OSError(errno.ENOSPC, "No space left on device")) == "space"
    assert transient(OperationalError("x", {}, sqlite3.OperationalError("database or disk is full"))) == "space"
    assert transient(OperationalError("x", {}, sqlite3.OperationalError("database is locked"))) == "connection"
    assert transient(IntegrityError("x", {}, sqlite3.IntegrityError("UNIQUE constraint failed"))) is None
    assert transient(ValueError("bad numbers")) is None
    assert transient(OSError(errno.EACCES, "Permission denied")) is None


def test_a_broker_restart_unsends_its_messages_so_they_are_resent_and_leave_the_window(url):
    a, b, c = new_job(url), new_job(url), new_job(url)
    t0 = utcnow()
    with session_scope(url) as s:
        repo.mark_dispatched(s, [a, b], now=t0 - dt.timedelta(seconds=10))
        repo.mark_dispatched(s, [c], now=t0 + dt.timedelta(seconds=1))
        assert select_fair(s, 2) == []  # a and b fill alice's window of 2 (c too)
        assert sorted(repo.undispatch_before(s, t0)) == sorted([a, b])  # Redis started at t0
        assert repo.undispatch_before(s, t0) == []  # a second housekeeper finds nothing to do
    with session_scope(url) as s:
        assert select_fair(s, 2) == [a]  # c counts, a and b do not: one slot of the window is free
        assert select_fair(s, 3) == [a, b]
        # a message presumed lost (stale_before) is sent again and does not count either
        assert select_fair(s, 1, stale_before=t0 + dt.timedelta(seconds=5)) == [a]


def test_study_points_are_held_and_fed_within_the_owners_share(url):
    held = [new_job(url, held=True) for _ in range(7)]
    single = new_job(url)
    with session_scope(url, readonly=True) as s:
        assert repo.count_queued(s, "alice") == 1  # held points do not count against the limit
    with session_scope(url) as s:
        assert repo.claim(s, held[0], worker="w", lease_s=30) is None  # never run before it is admitted
        assert select_fair(s, 10) == [single]
    with session_scope(url) as s:
        assert feed(s, max_queued=8) == 3  # share 4: the single job and three points
    with session_scope(url, readonly=True) as s:
        assert repo.count_queued(s, "alice") == 4 == study_share(8)
        assert [j.id for j in s.scalars(select(Job).where(Job.held.is_(False)).order_by(Job.seq))] == [*held[:3], single]
    with session_scope(url) as s:
        repo.request_cancel(s, held[6], None)  # a held point can be cancelled like any queued job
        assert feed(s, max_queued=8) == 0


def _drive(settings, client, n_points: int, max_rounds: int = 400) -> tuple[str, int]:
    """Run a study's points as workers would (take what was sent, claim, finish, refill),
    with a list standing in for the broker."""
    from app.service.dispatch import fair_next

    r = client.post("/api/studies", json={"name": "big", "base": BASE, "report": {"metrics": ["best.fitness"]},
                                          "grid": {"search.seed": list(range(n_points))}})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    with session_scope(settings.db_url, readonly=True) as s:
        broker = list(s.scalars(select(Job.id).where(Job.dispatched_at.is_not(None))))
    assert broker, "the study's first points were sent"
    peak = 0
    for _ in range(max_rounds):
        if not broker:
            break
        for jid in broker:
            with session_scope(settings.db_url) as s:
                claim = repo.claim(s, jid, worker="w", lease_s=30)
            with session_scope(settings.db_url) as s:
                assert repo.finish(s, claim, "succeeded", summary={"best": {"fitness": 1.0}})
        with session_scope(settings.db_url) as s:  # what a worker does after each job (dispatch.refill)
            feed(s, settings.max_queued_per_owner)
            peak = max(peak, repo.count_queued(s, "local"))
            broker = fair_next(s, settings)
            repo.mark_dispatched(s, broker)
    return sid, peak


def test_a_300_point_study_is_accepted_and_runs_to_the_end_with_the_default_limits(tmp_path, database_url):
    from app.api import create_app

    settings = migrated(deployment(tmp_path, database_url=database_url))
    assert settings.max_queued_per_owner == 100  # the default
    client = TestClient(create_app(settings))
    sid, peak = _drive(settings, client, 300)
    st = client.get(f"/api/studies/{sid}").json()
    assert st["status"] == "succeeded" and st["progress"]["done"] == 300, st["progress"]
    assert 0 < peak <= study_share(settings.max_queued_per_owner)  # fed gradually, within the limit
    # while a study is fed, the owner's own jobs are still accepted
    r = client.post("/api/studies", json={"name": "again", "base": BASE, "report": {"metrics": ["best.fitness"]},
                                          "grid": {"search.seed": list(range(300))}})
    assert r.status_code == 201 and r.json()["progress"]["queued"] == 300, r.text
    assert client.post("/api/jobs", json=BASE).status_code == 201


def _worker(url, name, slots=1, seen=None):
    with session_scope(url) as s:
        repo.worker_seen(s, name, "embedded", slots)
        if seen is not None:
            s.execute(update(Worker).where(Worker.name == name).values(last_seen_at=seen))


def test_health_is_degraded_while_jobs_wait_with_idle_or_no_workers_and_on_low_disk(tmp_path):
    from app.service.health import assess

    settings = migrated(deployment(tmp_path, stall_after_s=5, min_free_mb=0))
    url = settings.db_url
    assert assess(settings)["status"] == "ok"
    jid = new_job(url)
    with session_scope(url) as s:  # queued 10 s ago
        s.execute(update(Job).where(Job.id == jid).values(updated_at=utcnow() - dt.timedelta(seconds=10)))
    h = assess(settings)
    assert h["status"] == "degraded" and "no worker is connected" in h["reasons"][0], h
    _worker(url, "w1", slots=2)
    h = assess(settings)
    assert h["status"] == "degraded" and "2 of 2 worker slot(s) sit idle" in h["reasons"][0], h
    busy = [new_job(url), new_job(url)]
    for b in busy:
        with session_scope(url) as s:
            repo.claim(s, b, worker="w", lease_s=30)
    assert assess(settings)["status"] == "ok"  # every slot busy: waiting is not a stall
    _worker(url, "w1", slots=2, seen=utcnow() - dt.timedelta(minutes=5))  # no longer live
    assert "no worker is connected" in assess(settings)["reasons"][0]
    low = settings.model_copy(update={"min_free_mb": 1024 * 1024})
    h = assess(low)
    assert any(r.startswith("disk: ") and str(settings.data_dir.resolve()) in r for r in h["reasons"]), h
    assert h["disk"]["low"] is True and h["disk"]["free_bytes"] > 0


def test_the_sweep_applies_retention_and_leaves_no_leftovers(tmp_path):
    from app.store.space import RESERVE, sweep

    settings = migrated(deployment(tmp_path, bundle_retention_days=1, checkpoint_retention_days=2, space_reserve_mb=1))
    url = settings.db_url
    old, recent = new_job(url), new_job(url)
    settings.bundle_dir.mkdir(parents=True)
    for jid, days in ((old, 3), (recent, 0)):
        bundle = settings.bundle_dir / f"{jid}.zip"
        bundle.write_bytes(b"zip")
        with session_scope(url) as s:
            claim = repo.claim(s, jid, worker="w", lease_s=30)
            repo.save_checkpoint(s, claim, '{"g": 1}')
        with session_scope(url) as s:
            repo.finish(s, claim, "failed", error="x", bundle_path=str(bundle))
            s.execute(update(Job).where(Job.id == jid).values(finished_at=utcnow() - dt.timedelta(days=days)))
    part = settings.bundle_dir / "dead.zip.part"
    part.write_bytes(b"half")
    os.utime(part, (time.time() - 7200, time.time() - 7200))
    empty = settings.artifact_dir / ("0" * 32)
    empty.mkdir(parents=True)
    os.utime(empty, (time.time() - 7200, time.time() - 7200))
    for i in range(50):  # grow the write-ahead log
        new_job(url)
    wal = settings.data_dir / "gaitmend.db-wal"
    assert wal.stat().st_size > 0
    out = sweep(settings)
    assert out == {"bundles": 1, "checkpoints": 1, "parts": 1, "folders": 1}
    assert not (settings.bundle_dir / f"{old}.zip").exists() and (settings.bundle_dir / f"{recent}.zip").exists()
    with session_scope(url, readonly=True) as s:
        assert repo.get_job(s, old).bundle_path is None
        assert [c.job_seq for c in s.scalars(select(JobCheckpoint))] == [repo.get_job(s, recent).seq]
    assert not part.exists() and not empty.exists()
    assert wal.stat().st_size == 0  # checkpointed and truncated
    from app.store.db import SQLITE_WAL_LIMIT_BYTES

    with session_scope(url, readonly=True) as s:  # and kept under a limit between sweeps
        assert s.execute(text("PRAGMA journal_size_limit")).scalar() == SQLITE_WAL_LIMIT_BYTES
    assert (settings.data_dir / RESERVE).stat().st_size == 1024 * 1024
    assert sweep(settings) == {"bundles": 0, "checkpoints": 0, "parts": 0, "folders": 0}

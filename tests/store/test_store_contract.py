"""The store's contract, run on SQLite and on PostgreSQL (the `database_url` fixture)."""

from __future__ import annotations

import datetime as dt
import time

import pytest
from sqlalchemy import insert, select
from sqlalchemy.exc import IntegrityError

from app.store import repo
from app.store.db import session_scope
from app.store.migrate import at_head, current, downgrade, head, upgrade
from app.store.models import ApiToken, Base, Job, utcnow


@pytest.fixture
def url(database_url):
    upgrade(database_url)
    return database_url


def new_job(url, owner="alice", key=None, **kw):
    with session_scope(url) as s:
        job = repo.create_job(s, owner=owner, kind=kw.get("kind", "recovery"), robot=kw.get("robot", "jethexa"),
                              spec={"kind": "recovery", "n": kw.get("n", 0)}, evaluations_budget=24,
                              max_attempts=kw.get("max_attempts", 3), idempotency_key=key)
        return job.id


def get(url, job_id):
    with session_scope(url, readonly=True) as s:
        return repo.get_job(s, job_id)


def test_migrations_reach_head_match_models_and_go_down_again(url):
    from alembic.autogenerate import compare_metadata
    from alembic.runtime.migration import MigrationContext

    from app.store.db import get_engine

    assert at_head(url) and current(url) == head(url)
    engine, _ = get_engine(url)
    with engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert diff == [], f"models and migrations differ: {diff}"
    downgrade(url, "base")
    assert current(url) is None
    upgrade(url)
    assert at_head(url)


def test_create_get_and_owner_isolation(url):
    jid = new_job(url)
    job = get(url, jid)
    assert (job.status, job.attempt, job.owner, job.cancel_requested) == ("queued", 0, "alice", False)
    assert job.created_at.tzinfo is not None and abs((utcnow() - job.created_at).total_seconds()) < 60
    with session_scope(url, readonly=True) as s:
        assert repo.get_job(s, jid, "alice").id == jid
        with pytest.raises(repo.NotFound):
            repo.get_job(s, jid, "mallory")
        with pytest.raises(repo.NotFound):
            repo.get_job(s, "nope")


def test_idempotency_key_is_unique_per_owner(url):
    new_job(url, key="k1")
    new_job(url, owner="bob", key="k1")  # another owner may reuse a key
    with pytest.raises(IntegrityError):
        new_job(url, key="k1")
    with session_scope(url, readonly=True) as s:
        assert repo.find_by_idempotency_key(s, "alice", "k1").owner == "alice"
        assert repo.find_by_idempotency_key(s, "alice", "k2") is None


def test_keyset_pagination_and_filters(url):
    ids = [new_job(url, owner="alice" if i % 3 else "bob", robot="jethexa" if i % 2 else "other") for i in range(30)]
    seen, before = [], None
    while True:
        with session_scope(url, readonly=True) as s:
            rows, nxt = repo.list_jobs(s, owner="alice", limit=7, before_seq=before)
        seen += [r.id for r in rows]
        if nxt is None:
            break
        before = nxt
    alice = [j for i, j in enumerate(ids) if i % 3]
    assert seen == alice[::-1]  # newest first, nothing lost or repeated
    with session_scope(url, readonly=True) as s:
        rows, _ = repo.list_jobs(s, owner=None, robot="other", limit=100)
        assert len(rows) == 15
        rows, _ = repo.list_jobs(s, owner=None, status="running", limit=100)
        assert rows == []
    assert repo.decode_cursor(repo.encode_cursor(12345)) == 12345
    with pytest.raises(ValueError):
        repo.decode_cursor("garbage!")


def test_listing_stays_fast_with_ten_thousand_jobs(url):
    now = utcnow()
    rows = [{"id": f"{i:032x}", "owner": "bulk" if i % 10 else "alice", "kind": "recovery", "robot": "jethexa",
             "status": ("queued", "succeeded", "failed")[i % 3], "spec": {"kind": "recovery"},
             "evaluations_budget": 1, "cancel_requested": False, "attempt": 0, "max_attempts": 3,
             "progress_done": 0, "progress_total": 0, "created_at": now, "updated_at": now} for i in range(10_000)]
    with session_scope(url) as s:
        s.execute(insert(Job), rows)
    t0 = time.perf_counter()
    with session_scope(url, readonly=True) as s:
        page, nxt = repo.list_jobs(s, owner="bulk", status="failed", limit=50)
        page2, _ = repo.list_jobs(s, owner="bulk", status="failed", limit=50, before_seq=nxt)
        deep, _ = repo.list_jobs(s, owner="alice", limit=50, before_seq=500)
    elapsed = time.perf_counter() - t0
    assert len(page) == len(page2) == 50 and all(j.status == "failed" for j in page + page2)
    assert len(deep) == 50
    assert elapsed < 0.5, f"three pages took {elapsed:.3f} s"


def test_claim_lease_fencing_and_finish(url):
    jid = new_job(url)
    with session_scope(url) as s:
        c = repo.claim(s, jid, worker="w1", lease_s=30)
    assert c.attempt == 1 and c.spec == {"kind": "recovery", "n": 0}
    with session_scope(url) as s:  # a live lease: nobody else gets it
        assert repo.claim(s, jid, worker="w2", lease_s=30) is None
    with session_scope(url) as s:
        assert repo.record_progress(s, c, 1, 4, {"best": 0.5}, lease_s=30)
    with session_scope(url) as s:
        assert repo.record_progress(s, c, 1, 4, {"best": 0.6}, lease_s=30)  # a resumed generation overwrites
        assert repo.save_checkpoint(s, c, '{"g": 1}')
    with session_scope(url) as s:
        assert repo.save_checkpoint(s, c, '{"g": 2}')
        assert repo.heartbeat(s, jid, c.lease_token, 30)
    with session_scope(url, readonly=True) as s:
        assert repo.load_checkpoint(s, jid) == '{"g": 2}'
        assert repo.checkpoint_saves(s, jid) == 2
        assert repo.history(s, repo.get_job(s, jid)) == [{"generation": 0, "best": 0.6}]
    stale = repo.Claim(c.job_id, c.seq, "not-the-token", c.attempt, c.spec)
    with session_scope(url) as s:
        assert not repo.heartbeat(s, jid, stale.lease_token, 30)
        assert not repo.save_checkpoint(s, stale, "{}")
        assert not repo.record_progress(s, stale, 2, 4, {}, 30)
        assert not repo.finish(s, stale, "succeeded")
    with session_scope(url) as s:
        assert repo.finish(s, c, "succeeded", summary={"best": 1.0}, bundle_path="/b.zip",
                           history_rows=[{"best": 0.1}, {"best": 0.2}])
    job = get(url, jid)
    assert (job.status, job.summary, job.lease_token) == ("succeeded", {"best": 1.0}, None)
    assert job.finished_at >= job.started_at
    with session_scope(url, readonly=True) as s:
        assert repo.history(s, job) == [{"best": 0.1}, {"best": 0.2}]
    with session_scope(url) as s:  # finished jobs are never claimed again
        assert repo.claim(s, jid, worker="w2", lease_s=30) is None


def test_reaper_requeues_expired_leases_then_fails_after_max_attempts(url):
    jid = new_job(url, max_attempts=2)
    later = utcnow() + dt.timedelta(seconds=60)
    for attempt in (1, 2):
        with session_scope(url) as s:
            c = repo.claim(s, jid, worker=f"w{attempt}", lease_s=5)
        assert c.attempt == attempt
        with session_scope(url) as s:
            assert repo.reap(s, now=utcnow()) == []  # lease still live
        with session_scope(url) as s:
            requeued = repo.reap(s, now=later)
        job = get(url, jid)
        if attempt == 1:
            assert requeued == [jid] and job.status == "queued" and job.lease_token is None
        else:
            assert requeued == [] and job.status == "failed"
    assert "worker lost 2 times" in get(url, jid).error


def test_reaper_cancels_a_dead_workers_job_that_was_asked_to_stop(url):
    jid = new_job(url)
    with session_scope(url) as s:
        repo.claim(s, jid, worker="w", lease_s=1)
    with session_scope(url) as s:
        repo.request_cancel(s, jid, None)
    with session_scope(url) as s:
        assert repo.reap(s, now=utcnow() + dt.timedelta(seconds=5)) == []
    assert get(url, jid).status == "cancelled"


def test_claim_of_an_expired_lease_counts_an_attempt_and_fences_the_old_worker(url):
    jid = new_job(url)
    with session_scope(url) as s:
        old = repo.claim(s, jid, worker="w1", lease_s=1)
    with session_scope(url) as s:
        new = repo.claim(s, jid, worker="w2", lease_s=30, now=utcnow() + dt.timedelta(seconds=5))
    assert new.attempt == 2
    with session_scope(url) as s:
        assert not repo.save_checkpoint(s, old, "{}")
        assert repo.save_checkpoint(s, new, "{}")


def test_cancel_retry_delete(url):
    queued, running = new_job(url), new_job(url)
    with session_scope(url) as s:
        c = repo.claim(s, running, worker="w", lease_s=30)
    with session_scope(url) as s:
        assert repo.request_cancel(s, queued, "alice").status == "cancelled"
        assert repo.request_cancel(s, running, "alice").status == "running"
    with session_scope(url) as s:
        assert repo.claim(s, queued, worker="w", lease_s=30) is None  # a cancelled job never starts
        assert repo.cancel_requested(s, running)
        with pytest.raises(repo.Conflict):
            repo.delete_job(s, running, "alice")
        with pytest.raises(repo.Conflict):
            repo.retry(s, running, "alice")
    with session_scope(url) as s:
        assert repo.save_checkpoint(s, c, '{"g": 1}')
        assert repo.finish(s, c, "cancelled")
    with session_scope(url) as s:
        job = repo.retry(s, running, "alice")
        assert (job.status, job.attempt, job.cancel_requested) == ("queued", 0, False)
    with session_scope(url, readonly=True) as s:
        assert repo.load_checkpoint(s, running) == '{"g": 1}'  # a retry resumes
    with session_scope(url) as s:
        repo.delete_job(s, queued, "alice")
        with pytest.raises(repo.NotFound):
            repo.delete_job(s, running, "bob")
    with session_scope(url, readonly=True) as s:
        with pytest.raises(repo.NotFound):
            repo.get_job(s, queued)


def test_undelivered_finds_unsent_and_long_unclaimed_messages(url):
    a, b = new_job(url), new_job(url)
    with session_scope(url) as s:
        repo.mark_dispatched(s, [a])
    with session_scope(url, readonly=True) as s:
        assert repo.undelivered(s, after_s=60) == [b]
        assert set(repo.undelivered(s, after_s=60, now=utcnow() + dt.timedelta(seconds=120))) == {a, b}


def test_tokens_are_stored_hashed(url):
    with session_scope(url) as s:
        tok = repo.create_token(s, "alice")
    with session_scope(url) as s:
        with pytest.raises(repo.Conflict):
            repo.create_token(s, "alice")
    with session_scope(url) as s:
        stored = s.scalars(select(ApiToken.token_hash)).all()
        assert tok not in stored and repo.hash_token(tok) in stored
        assert repo.resolve_token(s, tok) == "alice"
        assert repo.resolve_token(s, tok + "x") is None
    with session_scope(url) as s:
        assert repo.revoke_token(s, "alice")
    with session_scope(url) as s:
        assert repo.resolve_token(s, tok) is None


def test_concurrent_writers_all_succeed(url):
    """Many API threads writing at once: none sees 'database is locked' or loses a row."""
    import threading

    errors = []

    def writer(i):
        try:
            for k in range(10):
                new_job(url, owner=f"o{i}", key=f"k{k}")
        except Exception as e:  # noqa: BLE001 - collected and asserted below
            errors.append(repr(e))

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(12)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    with session_scope(url, readonly=True) as s:
        rows, _ = repo.list_jobs(s, owner=None, limit=500)
    assert len(rows) == 120


def test_workers_seen(url):
    with session_scope(url) as s:
        repo.worker_seen(s, "w@host", "embedded")
    with session_scope(url) as s:
        repo.worker_seen(s, "w@host", "embedded")
    with session_scope(url, readonly=True) as s:
        assert [w.name for w in repo.workers_seen(s, within_s=60)] == ["w@host"]

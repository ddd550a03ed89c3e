"""The runner's fault paths in this process against a real SQLite store (the real-process
versions with real signals, a real PostgreSQL and a real Redis are in tests/faults/):
SIGTERM hands the job back at the next generation boundary without spending an attempt,
the reaper gives the attempt back to a job whose stopping worker died, a dropped
connection is retried within the lease and a longer outage puts the job back in the
queue, and a job's own error is reported without SQL or tokens."""

from __future__ import annotations

import datetime as dt

import pytest
from service_support import checkpoint_saves, comparable, deployment, job_row, migrated, reference_run
from sqlalchemy import update
from sqlalchemy.exc import OperationalError

from app.jobs import registry
from app.service import runner
from app.service.runner import DbRunContext, run_job
from app.store import repo
from app.store.db import session_scope
from app.store.models import Job, utcnow

SPEC = {"kind": "ballistic", "search": {"population": 8, "generations": 8, "seed": 3}}


@pytest.fixture(autouse=True)
def ballistic():
    """The test kind, registered for these tests only (other tests iterate over the registry)."""
    before = dict(registry.KINDS)
    registry._load_extra("ballistic:KIND")
    yield
    registry.KINDS.clear()
    registry.KINDS.update(before)


@pytest.fixture(autouse=True)
def fresh_stop():
    def clear():
        runner.STOP.clear()
        runner._stop_at.clear()
        runner._signalled[0] = False

    clear()
    yield
    clear()


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path, lease_s=3))


def queued(settings, spec=SPEC) -> str:
    with session_scope(settings.db_url) as s:
        return repo.create_job(s, owner="local", kind=spec["kind"], robot="ball", spec=spec,
                               evaluations_budget=80, max_attempts=3).id


def test_a_stop_request_hands_the_job_back_at_the_next_boundary_and_it_resumes_identically(settings, monkeypatch):
    reference, saves = reference_run(SPEC)
    jid = queued(settings)
    orig = DbRunContext.progress

    def progress(self, done, total, info):
        orig(self, done, total, info)
        if done == 3:
            runner.request_stop()  # what SIGTERM does

    monkeypatch.setattr(DbRunContext, "progress", progress)
    assert run_job(settings, jid) == "handed-back"
    job = job_row(settings, jid)
    assert (job.status, job.attempt, job.lease_token, job.interrupted_at) == ("queued", 0, None, None)
    assert job.dispatched_at is not None  # sent again at once for another worker
    assert checkpoint_saves(settings, jid) == 3  # nothing after the boundary was started
    assert run_job(settings, "x" * 32) == "handed-back"  # a stopping worker claims nothing
    runner.STOP.clear()
    runner._stop_at.clear()
    monkeypatch.setattr(DbRunContext, "progress", orig)
    assert run_job(settings, jid) == "succeeded"
    job = job_row(settings, jid)
    assert job.attempt == 1  # the handed-back attempt was not spent
    assert comparable(job.summary) == comparable(reference)
    assert checkpoint_saves(settings, jid) == saves  # resumed, not restarted
    assert not (settings.artifact_dir / jid).exists()  # no empty artifact folder left behind


def test_the_reaper_gives_the_attempt_back_when_a_stopping_worker_died(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:
        claim = repo.claim(s, jid, worker="host:1", lease_s=1)
    with session_scope(settings.db_url) as s:
        assert repo.interrupt_workers(s, ["host:1", "host:2"]) == {jid: "host:1"}
    with session_scope(settings.db_url) as s:
        assert repo.reap(s, now=utcnow() + dt.timedelta(seconds=5)) == [jid]
    job = job_row(settings, jid)
    assert (job.status, job.attempt, job.interrupted_at) == ("queued", 0, None)
    # without the stop request the attempt counts, and the last one fails the job
    with session_scope(settings.db_url) as s:
        s.execute(update(Job).where(Job.id == jid).values(max_attempts=1))
        claim = repo.claim(s, jid, worker="host:1", lease_s=1)
    assert claim.attempt == 1
    with session_scope(settings.db_url) as s:
        assert repo.reap(s, now=utcnow() + dt.timedelta(seconds=5)) == []
    job = job_row(settings, jid)
    assert job.status == "failed" and job.error.startswith("worker lost 1 times")


def test_a_claim_retried_after_a_lost_commit_answer_gets_the_same_claim(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:
        first = repo.claim(s, jid, worker="w", lease_s=30, token="t" * 32)
    with session_scope(settings.db_url) as s:
        again = repo.claim(s, jid, worker="w", lease_s=30, token="t" * 32)
    assert again == first and job_row(settings, jid).attempt == 1


def _dropped() -> OperationalError:
    import psycopg

    return OperationalError("UPDATE jobs SET lease_expires_at=%(x)s WHERE lease_token = %(t)s",
                            {"x": 1, "t": "f" * 32}, psycopg.OperationalError("server closed the connection"),
                            connection_invalidated=True)


def test_dropped_connections_are_retried_within_the_lease_and_the_job_is_not_failed(settings, monkeypatch):
    reference, _ = reference_run(SPEC)
    jid = queued(settings)
    calls = {"n": 0}
    orig = repo.record_progress

    def flaky(s, *a, **kw):  # every write of progress fails twice before it goes through
        calls["n"] += 1
        if calls["n"] % 3:
            raise _dropped()
        return orig(s, *a, **kw)

    monkeypatch.setattr(repo, "record_progress", flaky)
    assert run_job(settings, jid) == "succeeded"
    job = job_row(settings, jid)
    assert job.attempt == 1 and job.error is None and calls["n"] >= 27
    assert comparable(job.summary) == comparable(reference)


def test_an_outage_longer_than_the_lease_puts_the_job_back_without_failing_it(settings, monkeypatch):
    jid = queued(settings)

    def down(s, *a, **kw):
        raise _dropped()

    monkeypatch.setattr(repo, "save_checkpoint", down)
    t = utcnow()
    assert run_job(settings, jid) == "store-unavailable"
    assert (utcnow() - t).total_seconds() >= settings.lease_s * 0.9  # retried for the lease
    job = job_row(settings, jid)
    assert (job.status, job.attempt, job.error) == ("queued", 1, None)  # the attempt is spent: no endless loop


def test_a_jobs_own_error_fails_it_with_a_message_free_of_sql_and_tokens(settings, monkeypatch):
    jid = queued(settings)

    def boom(self, done, total, info):
        raise _dropped().__class__("SELECT secret FROM jobs WHERE lease_token = %(t)s", {"t": "a" * 32},
                                   ValueError(f"bad numbers near {'a' * 32}"))

    monkeypatch.setattr(DbRunContext, "progress", boom)
    assert run_job(settings, jid) == "failed"
    err = job_row(settings, jid).error
    assert err.startswith("ValueError: bad numbers near"), err
    assert "a" * 32 not in err and "SELECT" not in err and "[SQL" not in err and "parameters" not in err


DEADLINE_RUN = """
import sys
from app.jobs import registry
registry._load_extra("ballistic:KIND")
from service_support import settings_of
import json, os
from app.service.runner import install_stop_handler, run_job
env = json.loads(sys.argv[1])
# From the third batch on, a generation never ends (as a long simulation would not before
# the grace runs out): only the stop deadline can hand the job back.
import time
from mujoco import rollout
real, calls = rollout.rollout, [0]
def slow(*a, **kw):
    calls[0] += 1
    if calls[0] > 2:
        time.sleep(600)
    return real(*a, **kw)
rollout.rollout = slow
install_stop_handler()
print("result", run_job(settings_of(env), sys.argv[2]), flush=True)
"""


def test_a_stop_inside_a_long_generation_hands_the_job_back_from_its_last_checkpoint_and_ends_the_process(tmp_path):
    """GAITMEND_STOP_GRACE_S=0: SIGTERM while a generation runs; the process does not wait
    for the boundary: the job goes back from its last checkpoint and the process ends."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    from service_support import wait_for

    env = deployment(tmp_path, lease_s=30, stop_grace_s=0)
    settings = migrated(env)
    spec = {"kind": "ballistic", "search": {"population": 8, "generations": 20, "seed": 3}}
    jid = queued(settings, spec)
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = subprocess.Popen([sys.executable, "-c", DEADLINE_RUN, json.dumps(env), jid], stdout=subprocess.PIPE,
                         text=True, env=os.environ | {"PYTHONPATH": os.pathsep.join([tests, os.path.join(tests, "kinds")])})
    try:
        wait_for(lambda: checkpoint_saves(settings, jid) >= 2, 60, "two checkpoints")
        time.sleep(0.5)  # inside the third generation, which never ends
        p.send_signal(signal.SIGTERM)
        t0 = time.monotonic()
        out, _ = p.communicate(timeout=20)
    finally:
        p.kill()
    assert time.monotonic() - t0 < 5 and "result" not in out  # it did not run on to the boundary and return
    job = job_row(settings, jid)
    assert (job.status, job.attempt, job.lease_token) == ("queued", 0, None)  # handed back, attempt not spent
    saves = checkpoint_saves(settings, jid)
    assert saves == 2 and job.progress_done == 2  # from the last checkpoint: the generation in flight was dropped

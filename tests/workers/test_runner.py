"""The runner in this process against a real SQLite store: what a worker does with a job
whose spec went bad, a job past its time limit, and a job whose lease another worker took."""

from __future__ import annotations

import datetime as dt
import time

import pytest
from service_support import SMALL, deployment, job_row, migrated
from sqlalchemy import update

from app.service.runner import DbRunContext, JobTimeout, LeaseLost, run_job
from app.store import repo
from app.store.db import session_scope
from app.store.models import Job, utcnow


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path, max_job_s=10))


def queued(settings, spec=SMALL) -> str:
    with session_scope(settings.db_url) as s:
        return repo.create_job(s, owner="local", kind="recovery", robot="jethexa", spec=spec,
                               evaluations_budget=24, max_attempts=3).id


def test_a_spec_that_no_longer_validates_fails_at_once_with_the_field(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:  # e.g. a kind removed since it was queued
        s.execute(update(Job).where(Job.id == jid).values(spec=SMALL | {"kind": "retired"}))
    assert run_job(settings, jid) == "failed"
    job = job_row(settings, jid)
    assert job.attempt == 1 and job.error.startswith("kind: unknown kind 'retired'")
    assert run_job(settings, jid) == "skipped"  # no retry loop


def test_cancelled_and_missing_jobs_are_skipped(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:
        repo.request_cancel(s, jid, None)
    assert run_job(settings, jid) == "skipped"
    assert run_job(settings, "does-not-exist") == "skipped"
    assert job_row(settings, jid).attempt == 0


def test_a_job_past_max_job_s_stops_at_its_next_generation(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:
        claim = repo.claim(s, jid, worker="t", lease_s=30)
    ctx = DbRunContext(settings, claim)
    assert ctx.is_cancelled() is False
    ctx._t0 = time.monotonic() - settings.max_job_s - 1
    with pytest.raises(JobTimeout, match="max_job_s=10"):
        ctx.is_cancelled()


def test_a_worker_whose_lease_was_taken_stops_writing(settings):
    jid = queued(settings)
    with session_scope(settings.db_url) as s:
        mine = repo.claim(s, jid, worker="slow", lease_s=1)
    ctx = DbRunContext(settings, mine)
    ctx.save_checkpoint({"generation": 1})
    with session_scope(settings.db_url) as s:  # the lease ran out and another worker took the job
        theirs = repo.claim(s, jid, worker="other", lease_s=30, now=utcnow() + dt.timedelta(seconds=5))
    assert theirs.attempt == 2
    with pytest.raises(LeaseLost):
        ctx.progress(2, 4, {"best": 1.0})
    with pytest.raises(LeaseLost):
        ctx.is_cancelled()
    assert ctx.load_checkpoint() == {"generation": 1}  # the new owner resumes from here
    assert job_row(settings, jid).worker == "other"

"""Real Celery worker processes on the embedded (filesystem) broker and on Redis, a real
store, no eager mode: lifecycle, cancel, kill -9 and resume, a job that kills its worker."""

from __future__ import annotations

import json
import os
import signal
import time
import zipfile

import pytest
from fastapi.testclient import TestClient
from service_support import (SMALL, Proc, checkpoint_saves, comparable, deployment, job_row, migrated, reference_run,
                             reference_result, spec, wait_for)

from app.api import create_app
from app.results import observed

FINAL = ("succeeded", "failed", "cancelled")


@pytest.fixture
def start_worker(tmp_path):
    procs = []

    def start(env, n=0):
        p = Proc(["worker", "--loglevel", "INFO"], env, tmp_path / f"worker{len(procs)}.log")
        procs.append(p)
        return p

    yield start
    for p in procs:  # throw-away deployment: no need to wait for a warm shutdown
        p.kill9()
        p.stop()


def submit(client, body) -> str:
    r = client.post("/api/jobs", json=body)
    assert r.status_code == 201, r.text
    return r.json()["id"]


def wait_final(settings, jid, timeout, proc=None):
    return wait_for(lambda: (j := job_row(settings, jid)).status in FINAL and j, timeout, f"job {jid} to finish",
                    proc=proc)


def pool_child_pid(settings, jid) -> int:
    """job.worker is host:pid of the pool process that claimed the job."""
    return int(job_row(settings, jid).worker.rsplit(":", 1)[1])


def test_lifecycle_events_result_and_bundle(tmp_path, start_worker):
    env = deployment(tmp_path)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    jid = submit(client, SMALL)
    w = start_worker(env)
    events, deadline = [], time.monotonic() + 90
    with client.stream("GET", f"/api/jobs/{jid}/events") as r:
        for line in r.iter_lines():
            if line.startswith("data: "):
                events.append(json.loads(line[6:]))
            assert time.monotonic() < deadline, f"no final event; worker log:\n{w.tail()}"
    statuses = [e["status"] for e in events]
    assert statuses[0] == "queued" and statuses[-1] == "succeeded", statuses
    assert "running" in statuses, statuses  # progress went out while it ran
    job = client.get(f"/api/jobs/{jid}").json()
    assert job["attempt"] == 1 and job["error"] is None
    assert job["progress"]["done"] == job["progress"]["total"] > 0
    assert job["started_at"] <= job["finished_at"] and job["wall_s"] > 0
    assert comparable(job["summary"]) == comparable(reference_result(SMALL))
    hist = client.get(f"/api/jobs/{jid}/history").json()
    assert [h["generation"] for h in hist] == [0, 1, 2, 3] and hist == job["summary"]["history"]
    r = client.get(f"/api/jobs/{jid}/bundle")
    assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
    (tmp_path / "b.zip").write_bytes(r.content)
    with zipfile.ZipFile(tmp_path / "b.zip") as z:
        man = json.loads(z.read("manifest.json"))
        assert {"result.json", "history.csv", "robot.xml", "README.md"} <= set(z.namelist())
    assert man["job_id"] == jid and man["spec"] == job["spec"]
    health = client.get("/api/health").json()
    assert health["status"] == "ok" and len(health["workers"]) == 1
    assert f".{w.pid}@" in health["workers"][0]["name"]


def test_cancel_stops_a_running_search_within_a_generation_and_a_queued_job_never_starts(tmp_path, start_worker):
    env = deployment(tmp_path)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    long_job = submit(client, spec(generations=200, population=6))
    waiting = submit(client, SMALL)
    w = start_worker(env)  # one task slot: `waiting` stays queued behind `long_job`
    wait_for(lambda: job_row(settings, long_job).progress_done >= 2, 60, "two generations", proc=w)
    assert client.post(f"/api/jobs/{waiting}/cancel").json()["status"] == "cancelled"
    assert client.post(f"/api/jobs/{long_job}/cancel").json()["cancel_requested"] is True
    gen_at_cancel = job_row(settings, long_job).progress_info["generation"]  # read after the flag is set
    job = wait_final(settings, long_job, 30, proc=w)
    assert job.status == "cancelled" and job.bundle_path is None
    # progress counts simulated walks (a generation is `population` of them): at most the
    # generation running when the flag was set finishes
    assert job.progress_info["generation"] <= gen_at_cancel + 1, (gen_at_cancel, job.progress_info)
    time.sleep(1.5)  # the worker is free now: the cancelled queued job must still not start
    q = job_row(settings, waiting)
    assert (q.status, q.attempt, q.started_at) == ("cancelled", 0, None)
    assert "job %s attempt" % waiting not in w.log.read_text()


RESUME_SPEC = spec(generations=18, population=8, seed=7)
_reference: list[tuple[dict, int]] = []


def resume_reference() -> tuple[dict, int]:
    """RESUME_SPEC's uninterrupted run, once per session (both brokers' tests compare with it)."""
    if not _reference:
        _reference.append(reference_run(RESUME_SPEC))
    return _reference[0]


def kill_and_resume(settings, client, jid, start_worker, env, kill, saves: int) -> dict:
    """Wait for a few checkpoints, kill -9, let a worker resume; returns timings. `saves`:
    the checkpoints an uninterrupted run saves."""
    wait_for(lambda: checkpoint_saves(settings, jid) >= 4, 90, "four checkpoints")
    first_worker = job_row(settings, jid).worker
    t_kill = time.monotonic()
    kill()
    killed_at_saves = checkpoint_saves(settings, jid)
    assert killed_at_saves < saves and job_row(settings, jid).status == "running"  # killed mid-search
    restarted = wait_for(lambda: (j := job_row(settings, jid)).attempt == 2 and j.status == "running" and j,
                         60, "the job to be claimed again")
    t_resumed = time.monotonic()
    job = wait_final(settings, jid, 120)
    t_done = time.monotonic()
    assert job.status == "succeeded", job.error
    assert job.attempt == 2
    # resumed, not restarted: the second attempt started from the saved generations
    hist = client.get(f"/api/jobs/{jid}/history").json()
    assert len(hist) == 19
    # Resumed, not restarted: as many checkpoints in all as an uninterrupted run saves. A
    # restart from generation 0 would have saved the generations done before the kill again.
    assert checkpoint_saves(settings, jid) == saves
    assert restarted.worker != first_worker
    return {"kill_to_resume_s": t_resumed - t_kill, "kill_to_done_s": t_done - t_kill}


def test_kill9_mid_search_resumes_to_the_same_result_embedded(tmp_path, start_worker):
    reference, saves = resume_reference()  # first: it must not race the job
    env = deployment(tmp_path)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    jid = submit(client, RESUME_SPEC)
    w1 = start_worker(env)
    holder = {}

    def kill():
        w1.kill9()  # the whole worker: main process and pool child
        holder["w2"] = start_worker(env)

    t = kill_and_resume(settings, client, jid, start_worker, env, kill, saves)
    print(f"embedded broker: kill -9 -> resumed in {t['kill_to_resume_s']:.1f} s, "
          f"finished {t['kill_to_done_s']:.1f} s after the kill")
    observed.record("worker.kill9_embedded_resume_s", [t["kill_to_resume_s"]], {"lease (s)": float(env["GAITMEND_LEASE_S"])})
    observed.record("worker.kill9_embedded_done_s", [t["kill_to_done_s"]], {"lease (s)": float(env["GAITMEND_LEASE_S"])})
    job = client.get(f"/api/jobs/{jid}").json()
    assert comparable(job["summary"]) == comparable(reference)


def test_kill9_mid_search_resumes_to_the_same_result_redis(tmp_path, start_worker, redis_url, pg_url):
    """The distributed mode: Redis broker and PostgreSQL store."""
    reference, saves = resume_reference()  # first: it must not race the job
    env = deployment(tmp_path, database_url=pg_url, broker=redis_url)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    w1 = start_worker(env)
    jid = submit(client, RESUME_SPEC)
    holder = {}

    def kill():
        w1.kill9()  # its message stays unacked in Redis; the lease reaper requeues the job
        holder["w2"] = start_worker(env)

    t = kill_and_resume(settings, client, jid, start_worker, env, kill, saves)
    health = client.get("/api/health").json()
    assert health["broker"] == "ok" and health["broker_url"].startswith("redis://")
    assert any(f".{holder['w2'].pid}@" in w["name"] for w in health["workers"])
    print(f"redis broker: kill -9 -> resumed in {t['kill_to_resume_s']:.1f} s, "
          f"finished {t['kill_to_done_s']:.1f} s after the kill")
    observed.record("worker.kill9_redis_resume_s", [t["kill_to_resume_s"]], {"lease (s)": float(env["GAITMEND_LEASE_S"])})
    observed.record("worker.kill9_redis_done_s", [t["kill_to_done_s"]], {"lease (s)": float(env["GAITMEND_LEASE_S"])})
    job = client.get(f"/api/jobs/{jid}").json()
    assert comparable(job["summary"]) == comparable(reference)


def test_a_job_that_kills_its_worker_three_times_fails_with_that_reason(tmp_path, start_worker):
    env = deployment(tmp_path)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    jid = submit(client, spec(generations=400, population=6))
    w = start_worker(env)
    for attempt in (1, 2, 3):
        wait_for(lambda: (j := job_row(settings, jid)).attempt == attempt and j.status == "running"
                 and j.progress_done >= 1, 60, f"attempt {attempt} running", proc=w)
        os.kill(pool_child_pid(settings, jid), signal.SIGKILL)  # the process running the job dies
    job = wait_final(settings, jid, 60, proc=w)
    assert job.status == "failed"
    assert job.error.startswith("worker lost 3 times"), job.error
    assert client.get(f"/api/jobs/{jid}").json()["error"] == job.error
    assert w.p.poll() is None  # the worker itself survived and keeps serving
    ok = submit(client, SMALL)
    assert wait_final(settings, ok, 60, proc=w).status == "succeeded"

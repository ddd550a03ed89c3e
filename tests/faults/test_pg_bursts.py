"""Issue 27, third fault: bursts of PostgreSQL backend terminations (what a failover, a
restart or a connection pooler does) while a distributed deployment (Redis, `gaitmend
serve`, two workers, a 5 s lease) runs a study fed through a small queue limit and
single jobs submitted during the bursts. Five bursts of 1.5 s, every backend of the
deployment killed every 30 ms. No job may fail or stick or spend an attempt, the
numbers must be the undisturbed ones, and every API answer must be a success or a
JSON 503 with Retry-After."""

from __future__ import annotations

import os
import threading
import time
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient
from fault_support import TcpGate, Watcher, ballistic, check_answers, new_name, pg_terminate
from service_support import SMALL, deployment, migrated, wait_for

from app.api import create_app
from app.results import observed

BURSTS, BURST_S, EVERY_S, GAP_S = 5, 1.5, 0.03, 1.5
PG_BASE = os.environ.get("GAITMEND_TEST_PG_URL", "postgresql://postgres@127.0.0.1:5432/test")  # as tests/conftest.py
POINT = ballistic(generations=6, population=16, seed=0)

pytestmark = pytest.mark.slow  # real processes and faults: tens of seconds


def test_bursts_of_terminated_postgresql_backends_fail_no_job(tmp_path, pg_url, redis_url, stacks):
    app = new_name("gmfault")
    url = pg_url.replace("postgresql://", "postgresql+psycopg://") + f"&application_name={app}"
    # db_retry_s short, so that some reads outlast their retries: their answer must be a JSON 503
    st = stacks(tmp_path, workers=2, database_url=url, broker=redis_url, max_queued_per_owner=4, db_retry_s=0.2)
    for w in st.workers:
        st.wait_ready(w)
    r = st.client.post("/api/studies", json={"name": "bursts", "base": POINT, "report": {"metrics": ["best.error_m"]},
                                             "grid": {"search.seed": list(range(8))}})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    killed: list[int] = []

    def bursts():
        for _ in range(BURSTS):
            end, n = time.monotonic() + BURST_S, 0
            while time.monotonic() < end:
                n += pg_terminate(PG_BASE, app)
                time.sleep(EVERY_S)
            killed.append(n)
            time.sleep(GAP_S)

    wait_for(lambda: any(j.status == "running" for j in st.rows().values()), 60, "a point running", proc=st.serve)
    killer = threading.Thread(target=bursts, daemon=True)
    singles = []
    with Watcher(st.base, ["/api/jobs?limit=5", f"/api/studies/{sid}"], every_s=0.1) as watch:
        killer.start()
        for i in range(4):  # submitted during the bursts (a 503 is retried after its Retry-After)
            singles.append(st.submit(ballistic(generations=4, population=12, seed=20 + i)))
            time.sleep(BURST_S)
        killer.join(120)
        rows = wait_for(lambda: (x := st.rows()) and len(x) == 12 and all(j.status in ("succeeded", "failed", "cancelled")
                                                                          for j in x.values()) and x,
                        120, "every job to finish", proc=st.serve)
    print(f"backends terminated per burst: {killed}; API answers: {len(watch.answers)}, "
          f"503s: {sum(1 for a in watch.answers if a[1] == 503)}")
    assert len(killed) == BURSTS and all(n > 0 for n in killed), killed  # the fault really happened
    observed.record("faults.pg_backends_per_burst", killed, {"bursts": BURSTS, "burst (s)": BURST_S,
                                                             "kill every (ms)": round(1000 * EVERY_S)})
    st.check_results({jid: j.spec for jid, j in rows.items()})
    assert {jid: j.attempt for jid, j in rows.items() if j.attempt != 1} == {}  # retried within the lease
    assert all(st.claims(jid) == 1 for jid in rows)
    # every 5xx was a JSON 503 (whether a read outlasted its retries during a burst is up to
    # timing; the next test takes the 503 path for certain)
    check_answers(watch.answers)
    assert sum(1 for a in watch.answers if a[1] == 200) > 20
    st_json = st.client.get(f"/api/studies/{sid}").json()
    assert st_json["status"] == "succeeded" and st_json["progress"]["done"] == 8, st_json["progress"]


def test_a_database_out_of_reach_answers_json_503_and_writes_nothing(tmp_path, pg_url):
    """The API's connection to PostgreSQL is cut (a relay in between drops every connection
    and refuses new ones) for longer than the API retries its reads: every read and every
    submission is a JSON 503 with Retry-After naming no SQL, and once the database is back
    nothing of the refused submission was written."""
    pg = urlsplit(pg_url)
    gate = TcpGate(pg.hostname, pg.port or 5432)
    try:
        url = pg_url.replace("postgresql://", "postgresql+psycopg://").replace(pg.netloc, f"{pg.username}@127.0.0.1:{gate.port}")
        client = TestClient(create_app(migrated(deployment(tmp_path, database_url=url, db_retry_s=0.3))))
        assert client.get("/api/jobs").status_code == 200  # the pool holds a connection through the relay
        gate.cut()
        answers = [(path, r.status_code, r.headers, r.text) for path in ("/api/jobs", "/api/studies", "/api/robots")
                   for r in [client.get(path)]]
        r = client.post("/api/jobs", json=SMALL)
        answers.append(("POST /api/jobs", r.status_code, r.headers, r.text))
        assert [a[1] for a in answers] == [503] * 4, answers
        assert check_answers(answers) == 4
        gate.open()
        r = client.get("/api/jobs")
        assert r.status_code == 200 and r.json()["items"] == [], r.text
    finally:
        gate.close()

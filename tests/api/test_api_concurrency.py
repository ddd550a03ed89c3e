"""Limits that must hold with many requests in flight and several API processes, on
PostgreSQL (READ COMMITTED: without the owner lock, 50 concurrent submissions against a
limit of 10 got 18-24 accepted). Two app instances stand for two API processes; every
request runs its transaction on its own connection."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated, spec
from sqlalchemy import func, select

from app.api import create_app
from app.store.db import session_scope
from app.store.models import Job


def _jobs(settings) -> int:
    with session_scope(settings.db_url, readonly=True) as s:
        return s.scalar(select(func.count()).select_from(Job))


@pytest.fixture(params=["postgresql", "sqlite"])
def backend(request, tmp_path):
    return request.getfixturevalue("pg_url") if request.param == "postgresql" else None


def _clients(tmp_path, database_url, **overrides):
    settings = migrated(deployment(tmp_path, database_url, **overrides))
    return settings, [TestClient(create_app(settings)) for _ in range(2)]


def test_fifty_simultaneous_submissions_against_a_limit_of_ten_accept_exactly_ten(tmp_path, backend):
    settings, clients = _clients(tmp_path, backend, max_queued_per_owner=10)
    gate = threading.Barrier(50)

    def submit(i):
        gate.wait()
        return clients[i % 2].post("/api/jobs", json=spec(seed=i)).status_code

    with ThreadPoolExecutor(50) as pool:
        codes = list(pool.map(submit, range(50)))
    print(f"\nquota ({settings.db_url.split(':')[0]}): 50 simultaneous, limit 10 -> "
          f"{codes.count(201)} accepted, {codes.count(429)} refused, other {sorted(set(codes) - {201, 429})}")
    assert codes.count(201) == 10 and codes.count(429) == 40, codes
    assert _jobs(settings) == 10


def test_two_hundred_keys_each_sent_twice_by_twenty_threads_give_two_hundred_jobs(tmp_path, backend):
    settings, clients = _clients(tmp_path, backend, max_queued_per_owner=1000)
    work = [(k, c) for k in range(200) for c in range(2)]  # each key twice, the two sends adjacent
    results: dict[int, list] = {k: [] for k in range(200)}

    def submit(item):
        k, copy = item
        r = clients[copy].post("/api/jobs", json=spec(seed=k), headers={"Idempotency-Key": f"key-{k}"})
        results[k].append((r.status_code, r.json().get("id")))

    with ThreadPoolExecutor(20) as pool:
        list(pool.map(submit, work))
    codes = sorted(c for rs in results.values() for c, _ in rs)
    print(f"\nidempotency ({settings.db_url.split(':')[0]}): 400 requests, 200 keys -> "
          f"{codes.count(201)} created, {codes.count(200)} replayed, jobs stored {_jobs(settings)}")
    assert _jobs(settings) == 200
    for k, rs in results.items():
        assert sorted(c for c, _ in rs) == [200, 201], (k, rs)
        assert rs[0][1] == rs[1][1], (k, rs)  # the retry got the first job back

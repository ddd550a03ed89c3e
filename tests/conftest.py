"""Fixtures for the job-service tests: real SQLite and PostgreSQL databases, real Redis,
real worker processes. Each test gets its own data folder, PostgreSQL schema, queue name
and Redis key prefix, so runs in parallel do not collide."""

from __future__ import annotations

import os
import sys
import uuid

import pytest

sys.path.insert(0, os.path.dirname(__file__))  # tests/service_support.py

PG_BASE = os.environ.get("GAITMEND_TEST_PG_URL", "postgresql://postgres@127.0.0.1:5432/test")
REDIS_URL = os.environ.get("GAITMEND_TEST_REDIS_URL", "redis://127.0.0.1:6379/0")


@pytest.fixture
def pg_url():
    """A fresh schema in the test database; dropped afterwards."""
    import psycopg

    schema = f"gm_{uuid.uuid4().hex[:12]}"
    with psycopg.connect(PG_BASE, autocommit=True) as conn:
        conn.execute(f'CREATE SCHEMA "{schema}"')
    sep = "&" if "?" in PG_BASE else "?"
    yield f"{PG_BASE}{sep}options=-csearch_path%3D{schema}"
    with psycopg.connect(PG_BASE, autocommit=True) as conn:
        conn.execute(f'DROP SCHEMA "{schema}" CASCADE')


@pytest.fixture(params=["sqlite", "postgresql"])
def database_url(request, tmp_path):
    """The store's contract tests run once on each backend."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'store.db'}"
    return request.getfixturevalue("pg_url")


@pytest.fixture
def redis_url():
    import redis

    r = redis.Redis.from_url(REDIS_URL)
    r.ping()
    prefix = f"gmtest-{uuid.uuid4().hex[:10]}:"
    yield REDIS_URL, prefix
    keys = list(r.scan_iter(f"{prefix}*"))
    if keys:
        r.delete(*keys)

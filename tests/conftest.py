"""Fixtures for the job-service tests: real SQLite and PostgreSQL databases, real Redis,
real worker processes. Each test gets its own data folder, PostgreSQL schema, queue name
and Redis key prefix, so runs in parallel do not collide."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import pytest
from hypothesis import settings as hypothesis_settings
from hypothesis.configuration import set_hypothesis_home_dir

# Hypothesis keeps its example database and caches in ./.hypothesis by default: the suite
# must not write into the checkout (issue 16.11), and every property test is derandomised.
set_hypothesis_home_dir(os.path.join(tempfile.gettempdir(), "gaitmend-hypothesis"))
hypothesis_settings.register_profile("gaitmend", database=None)
hypothesis_settings.load_profile("gaitmend")

ROOT = Path(__file__).resolve().parent.parent

sys.path.insert(0, os.path.dirname(__file__))  # tests/service_support.py
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "kinds"))  # the contract tests' own kind

PG_BASE = os.environ.get("GAITMEND_TEST_PG_URL", "postgresql://postgres@127.0.0.1:5432/test")
REDIS_URL = os.environ.get("GAITMEND_TEST_REDIS_URL", "redis://127.0.0.1:6379/0")


def _copy_docs(dest: Path) -> Path:
    root = Path(__file__).resolve().parents[1]
    shutil.copy(root / "README.md", dest / "README.md")
    shutil.copytree(root / "docs", dest / "docs", ignore=shutil.ignore_patterns("*.png", "*.svg"))
    return dest


@pytest.fixture
def docs_copy(tmp_path):
    """README.md and docs/ (pages and data) copied: a repository a test may break."""
    return _copy_docs(tmp_path)


@pytest.fixture(scope="module")
def docs_copy_module(tmp_path_factory):
    """The same copy, once for a module whose tests each put back what they break."""
    return _copy_docs(tmp_path_factory.mktemp("docs"))


def unavailable(reason: str) -> None:
    """A service a test needs is not on this machine: skip with the reason, except in CI
    (the environment variable CI set), where every service must be there and its absence
    fails the test (issue 45: a newcomer's machine gets reasons, CI never passes by skipping)."""
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI is set, so a missing service fails instead of skipping)")
    pytest.skip(reason)


@pytest.fixture
def pg_url():
    """A fresh schema in the test database; dropped afterwards."""
    import psycopg

    schema = f"gm_{uuid.uuid4().hex[:12]}"
    try:
        conn = psycopg.connect(PG_BASE, autocommit=True, connect_timeout=5)
    except psycopg.OperationalError as e:
        unavailable(f"PostgreSQL is not reachable at {PG_BASE.split('@')[-1]} ({str(e).strip().splitlines()[0]}); "
                    "install it (scripts/test.sh starts an installed cluster) or set GAITMEND_TEST_PG_URL")
    with conn:
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
    try:
        r.ping()
    except redis.ConnectionError as e:
        unavailable(f"Redis is not reachable at {REDIS_URL} ({e}); install redis-server (scripts/test.sh starts "
                    "an installed one) or set GAITMEND_TEST_REDIS_URL")
    prefix = f"gmtest-{uuid.uuid4().hex[:10]}:"
    yield REDIS_URL, prefix
    keys = list(r.scan_iter(f"{prefix}*"))
    if keys:
        r.delete(*keys)


# -- which tests run alone -----------------------------------------------------------------------

def pytest_collection_modifyitems(config, items):
    """The fault-injection tests (tests/faults) bound how fast jobs move after a fault in wall
    time, against real services: scripts/test.sh runs them after the parallel part, alone."""
    faults = ROOT / "tests" / "faults"
    no_redis = shutil.which("redis-server") is None and not os.environ.get("CI")
    for item in items:
        if faults in Path(str(item.fspath)).parents:
            item.add_marker(pytest.mark.serial)
            # tests/faults/fault_support.RedisServer starts (and kills) its own redis-server
            if no_redis and "RedisServer" in getattr(getattr(item, "module", None), "__dict__", {}):
                item.add_marker(pytest.mark.skip(reason="redis-server is not installed (this test starts and kills "
                                                        "its own); CI installs it"))


# -- the suite writes nothing into the checkout (issue 16.11) ----------------------------------

def _untracked() -> set[str] | None:
    """Untracked and ignored paths of the checkout (a folder counts once), or None outside git."""
    try:
        out = subprocess.run(["git", "ls-files", "--others", "--directory", "--no-empty-directory", "-z"],
                             cwd=ROOT, capture_output=True, timeout=60, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return {p for p in out.decode(errors="replace").split("\0") if p and "__pycache__" not in p}


def pytest_sessionstart(session):
    session.config._gaitmend_untracked = _untracked()
    session.config._gaitmend_t0 = time.monotonic()


def _record_suite(session) -> None:
    """With GAITMEND_OBSERVED set, the wall time of a whole part of scripts/test.sh (every
    test file, `-m "not serial"` or `-m serial`), from the controller, with its counts."""
    from app.results import observed

    part = {"not serial": "parallel", "serial": "serial"}.get(session.config.option.markexpr)
    whole = [Path(a).resolve() for a in session.config.args] == [ROOT / "tests"]
    selected = session.config.option.keyword or session.config.option.deselect
    if part is None or not whole or selected or hasattr(session.config, "workerinput") \
            or not os.environ.get(observed.ENV):
        return
    stats = session.config.pluginmanager.get_plugin("terminalreporter").stats
    counts = {k: len(stats.get(k, [])) for k in ("passed", "failed", "skipped")}
    workers = getattr(session.config.option, "numprocesses", None) or 1
    observed.record(f"suite.{part}_s", [time.monotonic() - session.config._gaitmend_t0],
                    {"pytest workers": workers, **{f"tests {k}": n for k, n in counts.items()}})


def pytest_sessionfinish(session, exitstatus):
    _record_suite(session)
    before = getattr(session.config, "_gaitmend_untracked", None)
    after = _untracked()
    if before is None or after is None:
        return
    new = sorted(after - before)
    if new:
        session.config.get_terminal_writer().line(
            f"the tests wrote into the checkout {ROOT}: {new} (write under tmp_path instead)", red=True)
        session.exitstatus = 1

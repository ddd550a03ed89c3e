"""What a newcomer hits first (issue 46): create_app() served by uvicorn directly, without
`gaitmend serve`, on a database nothing migrated yet answers /api/robots (it answered 500
"no such table"), and refuses to start, saying how to fix it, when the migration fails;
/robots leads to the robots page (it answered 404)."""

from __future__ import annotations

import subprocess
import sys

import httpx
import pytest
from fastapi.testclient import TestClient
from service_support import deployment, free_port, proc_env, settings_of, wait_for
from sqlalchemy import text

from app.store.db import get_engine
from app.store.migrate import SchemaError, at_head, current


def _uvicorn(env: dict, port: int) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "uvicorn", "--factory", "app.api:create_app", "--host", "127.0.0.1",
                             "--port", str(port)], env=proc_env(env), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def test_uvicorn_alone_migrates_a_new_database_at_start_up(tmp_path):
    env = deployment(tmp_path)
    settings = settings_of(env)
    assert current(settings.db_url) is None  # nothing migrated it
    port = free_port()
    proc = _uvicorn(env, port)
    try:
        def up():
            assert proc.poll() is None, proc.stdout.read()
            try:
                return httpx.get(f"http://127.0.0.1:{port}/api/robots", timeout=2)
            except httpx.HTTPError:
                return None

        r = wait_for(up, 90, "uvicorn to answer /api/robots", interval=0.3)
        assert r.status_code == 200 and "jethexa" in r.text, r.text
        assert at_head(settings.db_url)
    finally:
        proc.terminate()
        out = proc.communicate(timeout=30)[0]
    assert "migrated the database from revision none (no tables)" in out, out


def test_a_migration_that_fails_refuses_the_start_and_says_how(tmp_path):
    env = deployment(tmp_path)
    settings = settings_of(env)
    engine, _ = get_engine(settings.db_url)
    with engine.begin() as conn:  # a revision this release does not know: alembic cannot move it
        conn.execute(text("CREATE TABLE alembic_version (version_num VARCHAR(32) NOT NULL)"))
        conn.execute(text("INSERT INTO alembic_version VALUES ('f00dfeed0000')"))
    from app.api import create_app

    with pytest.raises(SchemaError, match=r"revision f00dfeed0000, not \w+, and migrating it failed .*"
                                          r"run `gaitmend db upgrade`"):
        with TestClient(create_app(settings)):
            pass
    port = free_port()
    proc = _uvicorn(env, port)
    out = proc.communicate(timeout=90)[0]
    assert proc.returncode != 0 and "gaitmend db upgrade" in out, out


def test_robots_leads_to_the_robots_page(tmp_path):
    from app.api import create_app

    with TestClient(create_app(settings_of(deployment(tmp_path)))) as c:
        r = c.get("/robots", follow_redirects=False)
        assert r.status_code == 307 and r.headers["location"] == "/robots/new"
        page = c.get("/robots")
        assert page.status_code == 200 and "robot" in page.text.lower()

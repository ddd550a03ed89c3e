"""Bearer tokens: required off loopback, hashed at rest, and jobs visible to their owner only."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from service_support import SMALL, deployment, migrated

from app.api import create_app
from app.api.auth import auth_required, is_loopback
from app.store import repo
from app.store.db import session_scope


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path))


def tokens(settings, *names):
    with session_scope(settings.db_url) as s:
        return [repo.create_token(s, n) for n in names]


def test_auth_required_whenever_bound_off_loopback():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5") and not is_loopback("example.org")
    assert auth_required("auto", "0.0.0.0") and not auth_required("auto", "127.0.0.1")
    assert auth_required("on", "127.0.0.1") and not auth_required("off", "0.0.0.0")


def test_public_bind_rejects_missing_and_unknown_tokens(settings):
    client = TestClient(create_app(settings, host="0.0.0.0"))
    r = client.post("/api/jobs", json=SMALL)
    assert r.status_code == 401 and r.json()["errors"][0]["field"] == "Authorization"
    assert r.headers["www-authenticate"] == "Bearer"
    assert client.get("/api/jobs", headers={"Authorization": "Bearer nope"}).status_code == 401
    assert client.get("/api/jobs", headers={"Authorization": "Basic abc"}).status_code == 401
    assert client.get("/api/health").status_code == 200  # health stays open for probes


def test_jobs_belong_to_their_owner(settings):
    alice, bob = tokens(settings, "alice", "bob")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    A, B = ({"Authorization": f"Bearer {t}"} for t in (alice, bob))
    jid = client.post("/api/jobs", json=SMALL, headers=A).json()["id"]
    assert client.get(f"/api/jobs/{jid}", headers=A).json()["owner"] == "alice"
    for method, path in (("GET", ""), ("GET", "/history"), ("GET", "/events"), ("GET", "/bundle"),
                         ("POST", "/cancel"), ("POST", "/retry"), ("DELETE", "")):
        r = client.request(method, f"/api/jobs/{jid}{path}", headers=B)
        assert r.status_code == 404, (method, path, r.text)
    assert client.get("/api/jobs", headers=B).json()["items"] == []
    assert [j["id"] for j in client.get("/api/jobs", headers=A).json()["items"]] == [jid]
    # the same Idempotency-Key from another owner is another job
    ka = client.post("/api/jobs", json=SMALL, headers=A | {"Idempotency-Key": "k"}).json()["id"]
    kb = client.post("/api/jobs", json=SMALL, headers=B | {"Idempotency-Key": "k"}).json()["id"]
    assert ka != kb


def test_revoked_token_stops_working(settings):
    (tok,) = tokens(settings, "carol")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    H = {"Authorization": f"Bearer {tok}"}
    assert client.get("/api/jobs", headers=H).status_code == 200
    with session_scope(settings.db_url) as s:
        repo.revoke_token(s, "carol")
    assert client.get("/api/jobs", headers=H).status_code == 401


def test_loopback_without_auth_is_single_user(settings):
    client = TestClient(create_app(settings, host="127.0.0.1"))
    job = client.post("/api/jobs", json=SMALL).json()
    assert job["owner"] == "local"

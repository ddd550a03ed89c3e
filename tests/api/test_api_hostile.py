"""Hostile and careless requests, one test per class the adversarial pass found (issue 15):
each is a 4xx naming a field, never a 5xx, and writes nothing."""

from __future__ import annotations

import base64
import json
import time

import pytest
from fastapi.testclient import TestClient
from service_support import SMALL, deployment, job_count, migrated, spec
from sqlalchemy import func, select

from app.api import create_app
from app.store import repo
from app.store.db import session_scope
from app.store.models import Job

JSON = {"content-type": "application/json"}


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path))


@pytest.fixture
def client(settings):
    return TestClient(create_app(settings))


def small_text(**top) -> str:
    return json.dumps(SMALL | top)


@pytest.mark.parametrize("raw, field, words", [
    ("[" * 1000 + "]" * 1000, "body", "nested 1000 levels"),
    ('{"kind":"recovery","seed":' + "9" * 5000 + "}", "seed", "5000 digits"),
    (small_text()[:-1] + ',"sim":{"duration_s":1e999}}', "sim", "duplicate key"),
    ('{"kind":"recovery","kind":"tipping"}', "kind", "duplicate key"),
    ('{"kind":"recovery","sim":{"duration_s":NaN}}', "sim.duration_s", "NaN is not JSON"),
    ('{"kind":"recovery","sim":{"duration_s":-Infinity}}', "sim.duration_s", "not JSON"),
    ('{"kind":"recovery","sim":{"duration_s":1e400}}', "sim.duration_s", "finite"),
    ('{"kind":"recovery","robot":"\\ud800"}', "robot", "surrogate"),
    ('\ufeff{"kind":"recovery"}', "body", "byte-order mark"),
    ('{"kind": []}', "kind", "must be a string"),
    ('{"kind": {}}', "kind", "must be a string"),
    ('{"kind":"recovery","sim":{"duration_s":1e-320}}', "sim.duration_s", "too small"),
    ('{"kind":"recovery","sim":{"duration_s":1e-300}}', "sim.duration_s", "greater than or equal to 0.5"),
    ('{"kind":"recovery","search":{"population":"30"}}', "search.population", "valid integer"),
    ('{"kind":"recovery","search":{"population":30.0}}', "search.population", "valid integer"),
    ('{"kind":"recovery","damage":{"lost_legs":[true]}}', "damage.lost_legs.0", "valid integer"),
    ('{"kind":"recovery","damage":{"lost_legs":["1"]}}', "damage.lost_legs.0", "valid integer"),
    ('{"kind":"recovery","objective":{"weights":[1,1,10,100,1e308]}}', "objective.weights.4", "less than"),
    ('{"kind":"recovery","bounds":{"x0_m":[0, 1e308]}}', "bounds.x0_m.1", "less than"),
])
def test_bodies_that_used_to_escape_the_parser(client, settings, raw, field, words):
    r = client.post("/api/jobs", content=raw.encode("utf-8", "surrogatepass"), headers=JSON)
    assert r.status_code == 422, r.text
    errors = r.json()["errors"]
    assert any(e["field"] == field and words in e["message"] for e in errors), errors
    assert job_count(settings) == 0


def test_content_type_must_be_json(client, settings):
    for headers in ({}, {"content-type": "text/plain"}, {"content-type": "application/x-www-form-urlencoded"}):
        r = client.post("/api/jobs", content=json.dumps(SMALL), headers=headers)
        assert r.status_code == 415 and r.json()["errors"][0]["field"] == "Content-Type", r.text
    assert client.post("/api/jobs", content=json.dumps(SMALL),
                       headers={"content-type": "application/json; charset=utf-8"}).status_code == 201
    assert job_count(settings) == 1


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_cursor_out_of_range_is_never_a_5xx_on_both_backends(request, tmp_path, backend):
    url = request.getfixturevalue("pg_url") if backend == "postgresql" else None
    client = TestClient(create_app(migrated(deployment(tmp_path, url))))
    ids = [client.post("/api/jobs", json=spec(seed=i)).json()["id"] for i in range(2)]
    for big in ("9" * 19, "99999999999", "2147483648", "2147483647"):  # beyond any seq: the first page
        r = client.get("/api/jobs", params={"cursor": big})
        assert r.status_code == 200 and [j["id"] for j in r.json()["items"]] == ids[::-1], (big, r.text)
    for bad in ("9" * 20, "-1", " 5", "+5", "1_0", "1e3", "٣", base64.b64encode(b"s1").decode()):
        r = client.get("/api/jobs", params={"cursor": bad})
        assert r.status_code == 422 and r.json()["errors"][0]["field"] == "cursor", (bad, r.text)


def test_every_409_names_its_field(client):
    h = {"Idempotency-Key": "k"}
    assert client.post("/api/jobs", json=SMALL, headers=h).status_code == 201
    r = client.post("/api/jobs", json=spec(seed=7), headers=h)
    assert r.status_code == 409 and r.json()["errors"][0]["field"] == "Idempotency-Key"
    jid = client.post("/api/jobs", json=SMALL).json()["id"]
    r = client.post(f"/api/jobs/{jid}/retry")
    assert r.status_code == 409 and r.json()["errors"][0]["field"] == "status"
    r = client.get(f"/api/jobs/{jid}/bundle")
    assert r.status_code == 409 and r.json()["errors"][0]["field"] == "status"


def test_non_finite_numbers_a_kind_reports_are_stored_as_null(client, settings):
    jid = client.post("/api/jobs", json=SMALL).json()["id"]
    with session_scope(settings.db_url) as s:
        c = repo.claim(s, jid, worker="t", lease_s=30)
    with session_scope(settings.db_url) as s:
        repo.record_progress(s, c, 1, 2, {"best": float("nan"), "worst": float("-inf")}, 30)
    assert client.get(f"/api/jobs/{jid}/history").json() == [{"generation": 0, "best": None, "worst": None}]
    with session_scope(settings.db_url) as s:
        repo.finish(s, c, "succeeded", summary={"best": {"fitness": float("inf")}},
                    history_rows=[{"best": float("nan")}])
    r = client.get(f"/api/jobs/{jid}")
    assert r.status_code == 200 and r.json()["summary"] == {"best": {"fitness": None}}
    assert client.get(f"/api/jobs/{jid}/history").json() == [{"best": None}]


def test_health_with_auth_on_tells_strangers_only_the_status(settings):
    with session_scope(settings.db_url) as s:
        token = repo.create_token(s, "alice")
    with session_scope(settings.db_url) as s:
        repo.worker_seen(s, "gaitmend.4242@secret-host", "embedded")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    for headers in ({}, {"Authorization": "Bearer wrong"}):
        r = client.get("/api/health", headers=headers)
        assert r.status_code == 200 and set(r.json()) == {"status"}, r.text
        assert "secret-host" not in r.text
    full = client.get("/api/health", headers={"Authorization": f"Bearer {token}"}).json()
    assert [w["name"] for w in full["workers"]] == ["gaitmend.4242@secret-host"]


def test_signed_links_bound_exp_and_die_with_their_token(settings, tmp_path):
    import zipfile

    with session_scope(settings.db_url) as s:
        token = repo.create_token(s, "alice")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    auth = {"Authorization": f"Bearer {token}"}
    jid = client.post("/api/jobs", json=SMALL, headers=auth).json()["id"]
    bundle = tmp_path / "b.zip"
    with zipfile.ZipFile(bundle, "w") as z:
        z.writestr("replay.viser", b"frames")
    with session_scope(settings.db_url) as s:
        c = repo.claim(s, jid, worker="t", lease_s=30)
    with session_scope(settings.db_url) as s:
        repo.finish(s, c, "succeeded", summary={}, bundle_path=str(bundle))
    r = client.get(f"/api/jobs/{jid}/file-link", params={"path": "replay.viser"}, headers=auth)
    assert r.status_code == 200, r.text
    url = r.json()["url"]
    assert client.get(url).content == b"frames"  # no header: the link is the credential
    base = url.split("?")[0]
    sig = url.split("sig=")[1]
    for exp in ("9" * 5000, str(int(time.time()) + 10**9), "-1", "1e9", "٣"):
        r = client.get(base, params={"exp": exp, "sig": sig})
        assert r.status_code == 401, (exp[:20], r.status_code, r.text[:200])
    with session_scope(settings.db_url) as s:
        assert repo.revoke_token(s, "alice")
    assert client.get(url).status_code == 401  # revoked: its links stop working at once


def test_submit_does_not_wait_for_an_unreachable_redis(tmp_path, monkeypatch):
    from app.service import dispatch

    settings = migrated(deployment(tmp_path, broker=("redis://127.0.0.1:1/0", "gmtest-down:")))
    client = TestClient(create_app(settings))
    dispatch._celery(settings)  # imports and app set-up are not what is measured
    monkeypatch.setattr(dispatch, "BROKER_DOWN_S", 0.0)  # every submit really tries the broker
    took = []
    for i in range(3):
        t = time.monotonic()
        r = client.post("/api/jobs", json=spec(seed=i))
        took.append(time.monotonic() - t)
        assert r.status_code == 201 and r.json()["status"] == "queued"
    assert max(took) < 3.0, took  # kombu's default retries made each ~6 s
    with session_scope(settings.db_url, readonly=True) as s:
        assert repo.undelivered(s, after_s=3600) and len(repo.undelivered(s, after_s=3600)) == 3


def test_db_backup_copies_committed_rows_while_a_connection_is_open(settings, tmp_path):
    from app.store.backup import BackupError, backup

    client = TestClient(create_app(settings))
    for i in range(5):
        assert client.post("/api/jobs", json=spec(seed=i)).status_code == 201
    dest = tmp_path / "copy.db"
    out = backup(settings.db_url, dest)
    assert out["jobs"] == 5 and dest.stat().st_size == out["bytes"]
    copy_url = f"sqlite:///{dest}"
    with session_scope(copy_url, readonly=True) as s:
        assert s.scalar(select(func.count()).select_from(Job)) == 5
    with pytest.raises(BackupError, match="--force"):
        backup(settings.db_url, dest)
    with pytest.raises(BackupError, match="pg_dump"):
        backup("postgresql+psycopg://u:secret@h/db", tmp_path / "x")


def test_openapi_says_kind_is_required_and_cursor_is_digits(client):
    doc = client.get("/openapi.json").json()
    comps = doc["components"]["schemas"]
    for ref in comps["JobSpec"]["discriminator"]["mapping"].values():
        assert "kind" in comps[ref.rsplit("/", 1)[1]]["required"]
    cursor = next(p for p in doc["paths"]["/api/jobs"]["get"]["parameters"] if p["name"] == "cursor")
    assert "pattern" in str(cursor["schema"])
    dashboard = [(path, op) for path, ops in doc["paths"].items() for op in ops.values() if "dashboard" in op.get("tags", [])]
    assert len(dashboard) >= 3
    for path, op in dashboard:  # every route the dashboard adds declares its error body
        responses = op["responses"]
        assert {"401", "422"} <= set(responses), (path, set(responses))
        assert responses["422"]["content"]["application/json"]["schema"] == {"$ref": "#/components/schemas/ErrorOut"}

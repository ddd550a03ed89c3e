"""The HTTP API in-process against a real SQLite store and the embedded broker's folder
(no worker here: these tests are about what gets accepted, stored and shown)."""

from __future__ import annotations

import json
import threading

import pytest
from fastapi.testclient import TestClient
from service_support import SMALL, deployment, job_count, migrated, spec

from app.api import create_app
from app.jobs import registry
from app.robots.catalog import ROBOTS
from app.store import repo
from app.store.db import session_scope


@pytest.fixture
def env(tmp_path):
    return deployment(tmp_path)


@pytest.fixture
def settings(env):
    return migrated(env)


@pytest.fixture
def client(settings):
    return TestClient(create_app(settings))


def messages(settings) -> list:
    return [p for p in settings.broker_dir.glob("*.msg")]


def test_submit_stores_a_queued_job_and_sends_its_id(client, settings):
    r = client.post("/api/jobs", json=SMALL)
    assert r.status_code == 201, r.text
    job = r.json()
    assert job["status"] == "queued" and job["attempt"] == 0 and job["kind"] == "recovery"
    assert r.headers["location"] == f"/api/jobs/{job['id']}"
    assert job["spec"]["search"]["cr"] == 0.6  # defaults filled in, stored in full
    msgs = messages(settings)
    assert len(msgs) == 1 and job["id"] in msgs[0].read_text()
    got = client.get(f"/api/jobs/{job['id']}").json()
    assert got["id"] == job["id"] and got["progress"] == {"done": 0, "total": 0, "fraction": 0.0, "info": None,
                                                      "text": None}


@pytest.mark.parametrize("body, field, words", [
    ({**SMALL, "search": {"population": 2}}, "search.population", "greater than or equal to 4"),
    ({**SMALL, "damage": {"lost_legs": [7]}}, "damage.lost_legs.0", "less than or equal to 6"),
    ({**SMALL, "sim": {"duration_s": 1000}}, "sim.duration_s", "less than or equal to 120"),
    ({**SMALL, "colour": "red"}, "colour", "unknown field"),
    ({**SMALL, "kind": "teleport"}, "kind", "allowed"),
    ({"damage": {}}, "kind", "missing"),
    ({**SMALL, "robot": "r2d2"}, "robot", "allowed"),
    ([1, 2], "spec", "JSON object"),
])
def test_bad_input_is_a_4xx_naming_the_field_and_writes_nothing(client, settings, body, field, words):
    r = client.post("/api/jobs", json=body)
    assert r.status_code == 422, r.text
    errors = r.json()["errors"]
    assert any(e["field"] == field and words in e["message"] for e in errors), errors
    assert job_count(settings) == 0 and messages(settings) == []


def test_a_range_error_names_the_field_and_its_whole_range(client, settings):
    r = client.post("/api/jobs", json={"kind": "recovery", "search": {"population": 2}})
    assert r.status_code == 422, r.text
    body = r.json()
    assert body["errors"] == [{"field": "search.population", "message": "Input should be greater than or equal to 4; "
                                                                        "allowed: 4 <= population <= 1000"}]
    assert "search.population" in body["detail"] and "4 <= population <= 1000" in body["detail"]
    r = client.post("/api/jobs", json={**SMALL, "sim": {"duration_s": 1000}})
    assert r.json()["errors"] == [{"field": "sim.duration_s", "message": "Input should be less than or equal to 120; "
                                                                      "allowed: 0.5 <= duration_s <= 120 (in s)"}]
    r = client.post("/api/jobs", content=b'{"kind":"recovery","sim":{"duration_s":1e400}}',
                    headers={"content-type": "application/json"})
    assert r.status_code == 422 and "allowed: 0.5 <= duration_s <= 120" in r.json()["errors"][0]["message"]
    assert job_count(settings) == 0
    r = client.get("/api/jobs", params={"limit": 0})  # a query parameter's range comes from the OpenAPI schema
    assert r.status_code == 422 and r.json()["errors"] == [
        {"field": "limit", "message": "Input should be greater than or equal to 1; allowed: 1 <= limit <= 500"}]


def test_not_json_and_too_large_bodies(client, settings):
    r = client.post("/api/jobs", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "body"
    big = json.dumps(SMALL | {"pad": "x" * (settings.max_body_bytes + 10)})
    r = client.post("/api/jobs", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413 and "GAITMEND_MAX_BODY_BYTES" in r.json()["detail"]
    assert job_count(settings) == 0


def test_evaluation_budget_and_queue_limits(tmp_path):
    settings = migrated(deployment(tmp_path, max_evaluations_per_job=100, max_queued_per_owner=2))
    client = TestClient(create_app(settings))
    need = registry.parse_spec(spec(generations=20, population=6)).evaluations_budget  # search + controls + ...
    assert need > 100
    r = client.post("/api/jobs", json=spec(generations=20, population=6))
    assert r.status_code == 422
    assert r.json()["errors"] == [{"field": "search.generations", "message": r.json()["detail"]}]
    assert str(need) in r.json()["detail"] and "100" in r.json()["detail"]
    assert client.post("/api/jobs", json=SMALL).status_code == 201
    assert client.post("/api/jobs", json=SMALL).status_code == 201
    r = client.post("/api/jobs", json=SMALL)
    assert r.status_code == 429 and "GAITMEND_MAX_QUEUED_PER_OWNER" in r.json()["detail"]
    assert job_count(settings) == 2


def test_idempotency_key_returns_the_same_job(client, settings):
    h = {"Idempotency-Key": "abc-123"}
    first = client.post("/api/jobs", json=SMALL, headers=h)
    again = client.post("/api/jobs", json=SMALL, headers=h)
    assert (first.status_code, again.status_code) == (201, 200)
    assert first.json()["id"] == again.json()["id"]
    other = client.post("/api/jobs", json=spec(seed=2), headers=h)
    assert other.status_code == 409 and "Idempotency-Key" in other.json()["detail"]
    assert job_count(settings) == 1 and len(messages(settings)) == 1


def test_idempotency_key_under_concurrent_retries(client, settings):
    ids, statuses = [], []

    def post():
        r = client.post("/api/jobs", json=SMALL, headers={"Idempotency-Key": "same"})
        statuses.append(r.status_code)
        ids.append(r.json()["id"])

    threads = [threading.Thread(target=post) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(ids)) == 1 and sorted(statuses).count(201) == 1
    assert job_count(settings) == 1


def test_list_filters_and_cursor_pagination(client, settings):
    made = [client.post("/api/jobs", json=spec(seed=i)).json()["id"] for i in range(7)]
    client.post(f"/api/jobs/{made[0]}/cancel")
    seen, cursor = [], None
    while True:
        page = client.get("/api/jobs", params={"limit": 3} | ({"cursor": cursor} if cursor else {})).json()
        seen += [j["id"] for j in page["items"]]
        cursor = page["next_cursor"]
        if not cursor:
            break
    assert seen == made[::-1]
    assert [j["id"] for j in client.get("/api/jobs", params={"status": "cancelled"}).json()["items"]] == [made[0]]
    assert len(client.get("/api/jobs", params={"kind": "recovery", "robot": "jethexa"}).json()["items"]) == 7
    r = client.get("/api/jobs", params={"status": "sleeping"})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "status"
    r = client.get("/api/jobs", params={"cursor": "zzz"})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "cursor"
    r = client.get("/api/jobs", params={"limit": 0})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "limit"


def test_cancel_retry_delete_and_bundle_states(client, settings):
    jid = client.post("/api/jobs", json=SMALL).json()["id"]
    assert client.get(f"/api/jobs/{jid}/bundle").status_code == 409
    r = client.post(f"/api/jobs/{jid}/cancel")
    assert r.status_code == 202 and r.json()["status"] == "cancelled"
    r = client.post(f"/api/jobs/{jid}/retry")
    assert r.status_code == 202 and r.json()["status"] == "queued"
    assert client.post(f"/api/jobs/{jid}/retry").status_code == 409
    assert client.delete(f"/api/jobs/{jid}").status_code == 204
    for method, path in (("GET", ""), ("GET", "/history"), ("POST", "/cancel"), ("DELETE", ""), ("GET", "/bundle")):
        assert client.request(method, f"/api/jobs/{jid}{path}").status_code == 404


def test_events_end_with_the_final_state(client):
    jid = client.post("/api/jobs", json=SMALL).json()["id"]
    client.post(f"/api/jobs/{jid}/cancel")
    with client.stream("GET", f"/api/jobs/{jid}/events") as r:
        assert r.headers["content-type"].startswith("text/event-stream")
        text = "".join(r.iter_text())
    assert text.startswith("event: end\n")
    assert json.loads(text.split("data: ", 1)[1])["status"] == "cancelled"


def test_history_as_json_and_csv(client, settings):
    jid = client.post("/api/jobs", json=SMALL).json()["id"]
    with session_scope(settings.db_url) as s:
        c = repo.claim(s, jid, worker="t", lease_s=30)
    for g in (1, 2):
        with session_scope(settings.db_url) as s:
            repo.record_progress(s, c, g, 4, {"best": 0.1 * g, "evaluations": 6 * g}, 30)
    assert client.get(f"/api/jobs/{jid}/history").json() == [
        {"generation": 0, "best": 0.1, "evaluations": 6}, {"generation": 1, "best": 0.2, "evaluations": 12}]
    r = client.get(f"/api/jobs/{jid}/history", params={"format": "csv"})
    assert r.headers["content-type"].startswith("text/csv")
    assert r.text.splitlines()[0] == "generation,best,evaluations" and len(r.text.splitlines()) == 3
    job = client.get(f"/api/jobs/{jid}").json()
    assert job["status"] == "running" and job["progress"]["done"] == 2 and job["progress"]["fraction"] == 0.5


def test_robots_health_and_openapi(client):
    robots = {r["name"]: r for r in client.get("/api/robots").json()}
    assert set(robots) == set(ROBOTS) | {"heavy_hexapod", "lizard", "quadropod", "tshape", "lshape", "hshape", "silo6",
                                         "quadruped25"}
    assert robots["jethexa"]["kinds"] == ["recovery", "repertoire"] and robots["heavy_hexapod"]["kinds"] == ["tipping"]
    assert robots["lizard"]["kinds"] == ["multigait"] and robots["lizard"]["modules"] == 7
    assert robots["jethexa"]["legs"] == [1, 2, 3, 4, 5, 6] and "parameters" in robots["jethexa"]
    h = client.get("/api/health").json()
    assert h["database"] == "ok" and h["broker"] == "ok" and h["workers"] == []
    schema = client.get("/openapi.json").json()
    body = schema["paths"]["/api/jobs"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert body == {"$ref": "#/components/schemas/JobSpec"}
    comps = schema["components"]["schemas"]
    spec_schema = comps["JobSpec"]
    if len(registry.KINDS) > 1:  # one oneOf branch per registered kind, chosen by `kind`
        mapping = spec_schema["discriminator"]["mapping"]
        assert set(mapping) == set(registry.KINDS)
        assert all(ref.rsplit("/", 1)[1] in comps for ref in mapping.values())
    else:
        assert spec_schema["properties"]["kind"]["const"] == next(iter(registry.KINDS))
    assert client.get("/docs").status_code == 200


def test_openapi_body_is_a_union_over_every_registered_kind(monkeypatch):
    """The body schema follows the registry: a second kind appears as a oneOf branch on `kind`."""
    from typing import Literal

    from app.api.schemas import spec_json_schema
    from app.jobs import recovery, registry

    class Other(recovery.RecoverySpec):
        kind: Literal["other"] = "other"

    fake = type(recovery)("fake_kind")
    fake.Spec = Other
    monkeypatch.setitem(registry.KINDS, "other", fake)
    schema, defs = spec_json_schema()
    assert schema["discriminator"]["propertyName"] == "kind"
    assert {"RecoverySpec", "Other"} <= set(defs)

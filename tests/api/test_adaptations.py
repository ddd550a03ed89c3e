"""/api/adaptations in-process against a real SQLite store, with API tokens on (two owners):
a session over a finished repertoire job (a real map, built small here), trials posted
through the API until the stop rule, the proposal's zip, and every refusal a 4xx JSON that
names its field with nothing written."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated
from sqlalchemy import func, select

from app.api import create_app
from app.jobs.base import MemoryContext, dumps
from app.jobs.registry import get_kind, parse_spec
from app.store import repo
from app.store.adaptation_models import AdaptationRow, AdaptationTrial
from app.store.db import session_scope
from app.store.models import utcnow

SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 8, "checkpoint_every": 4},
        "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
        "evidence": {"rescore_elites": 0, "random_control": False}}
MEASURED = {"forward_m": -0.05,  # backwards: below any prediction, no early stop
            "lateral_m": 0.0, "yaw_deg": 1.5, "fell": False, "duration_s": 1.0}


@pytest.fixture(scope="module")
def summary():
    return json.loads(dumps(get_kind("repertoire").run(parse_spec(SPEC), MemoryContext()).summary))


@pytest.fixture
def served(tmp_path, summary):
    settings = migrated(deployment(tmp_path, auth="on"))
    with session_scope(settings.db_url) as s:
        tokens = {name: repo.create_token(s, name) for name in ("alice", "bob")}
        jobs = {}
        for owner in ("alice", "bob"):
            job = repo.create_job(s, owner=owner, kind="repertoire", robot="jethexa", spec=SPEC, evaluations_budget=1,
                                  max_attempts=3)
            job.status, job.summary, job.finished_at = "succeeded", summary, utcnow()
            jobs[owner] = job.id
        queued = repo.create_job(s, owner="alice", kind="repertoire", robot="jethexa", spec=SPEC,
                                 evaluations_budget=1, max_attempts=3).id
    app = create_app(settings, host="0.0.0.0")
    clients = {o: TestClient(app, headers={"Authorization": f"Bearer {tokens[o]}"}) for o in tokens}

    def client(owner):
        return clients[owner]

    return client, jobs, queued, settings


def _counts(settings):
    with session_scope(settings.db_url, readonly=True) as s:
        return (s.scalar(select(func.count()).select_from(AdaptationRow)),
                s.scalar(select(func.count()).select_from(AdaptationTrial)))


def _field(r):
    return [e["field"] for e in r.json()["errors"]]


def test_a_session_through_the_api(served):
    client, jobs, _, settings = served
    c = client("alice")
    r = c.post("/api/adaptations", json={"repertoires": [jobs["alice"]], "stop": {"max_trials": 3}, "name": "bench"})
    assert r.status_code == 201, r.text
    a = r.json()
    assert r.headers["location"] == f"/api/adaptations/{a['id']}" and a["owner"] == "alice"
    assert a["status"] == "open" and a["next"]["trial"] == 1 and a["decision"]["stop"] is False
    assert a["spec"]["method"] == "ite" and a["spec"]["stop"] == {"alpha": 0.9, "max_trials": 3}
    nexts = [a["next"]]
    for n in (1, 2, 3):
        r = c.post(f"/api/adaptations/{a['id']}/trials", json={"trial": n, **MEASURED, "note": f"run {n}"})
        assert r.status_code == 201, r.text
        out = r.json()
        assert out["trials_done"] == n and out["trials"][-1]["note"] == f"run {n}"
        assert (out["trials"][-1]["map"], out["trials"][-1]["elite"]) == (nexts[-1]["map"], nexts[-1]["elite"])
        nexts.append(out["next"])
    assert out["status"] == "finished" and out["next"] is None and "3 trials spent" in out["decision"]["reason"]
    listed = c.get(f"/api/adaptations/{a['id']}/trials").json()["items"]
    assert [t["trial"] for t in listed] == [1, 2, 3] and listed == out["trials"]
    assert c.get(f"/api/adaptations/{a['id']}").json()["trials"] == out["trials"]
    assert [x["id"] for x in c.get("/api/adaptations").json()["items"]] == [a["id"]]
    assert client("bob").get("/api/adaptations").json()["items"] == []
    # a stored trial's proposal, as a zip for the robot
    r = client("alice").get(f"/api/adaptations/{a['id']}/proposals/2/bundle")
    assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
    z = zipfile.ZipFile(io.BytesIO(r.content))
    assert {"gait.json", "setpoints.csv", "controller/repertoire_controller.py", "controller/layout.json",
            "README.md", "archive.csv"} <= set(z.namelist())
    assert json.loads(z.read("gait.json")) == nexts[1]
    r = c.get(f"/api/adaptations/{a['id']}/proposals/4/bundle")
    assert r.status_code == 404 and _field(r) == ["trial"]
    v = c.get(f"/api/adaptations/{a['id']}/views").json()["panels"]
    assert [p["id"] for p in v] == ["prior", "posterior"]
    assert [d["name"] for d in v[1]["figure"]["data"]] == ["elites", "tried"]  # finished: no next gait
    assert _counts(settings) == (1, 3)


def test_bad_requests_name_their_field_and_write_nothing(served):
    client, jobs, queued, settings = served
    c = client("alice")
    sid = c.post("/api/adaptations", json={"repertoires": [jobs["alice"]], "stop": {"max_trials": 1}}).json()["id"]
    url = f"/api/adaptations/{sid}/trials"
    cases = [
        (c.post("/api/adaptations", json={"repertoires": [jobs["bob"]]}), 404, ["repertoires.0"]),
        (c.post("/api/adaptations", json={"repertoires": [queued]}), 409, ["repertoires.0"]),
        (c.post("/api/adaptations", json={"repertoires": [jobs["alice"]], "colour": 1}), 422, ["colour"]),
        (c.post("/api/adaptations", content=b'{"repertoires": ["%s"], "trial_s": NaN}' % jobs["alice"].encode(),
                headers={"Content-Type": "application/json"}), 422, ["trial_s"]),
        (c.post(url, content=b'{"trial": 1, "forward_m": NaN, "lateral_m": 0, "yaw_deg": 0, "fell": false, '
                             b'"duration_s": 1}', headers={"Content-Type": "application/json"}), 422, ["forward_m"]),
        (c.post(url, content=b'{"trial": 1, "forward_m": 0, "lateral_m": Infinity, "yaw_deg": 0, "fell": false, '
                             b'"duration_s": 1}', headers={"Content-Type": "application/json"}), 422, ["lateral_m"]),
        (c.post(url, json={"trial": 1, **MEASURED, "speed": 2}), 422, ["speed"]),
        (c.post(url, json={"trial": 2, **MEASURED}), 409, ["trial"]),
        (client("bob").post(url, json={"trial": 1, **MEASURED}), 404, ["id"]),
        (client("bob").get(f"/api/adaptations/{sid}"), 404, ["id"]),
    ]
    for r, status, fields in cases:
        assert (r.status_code, _field(r)) == (status, fields), r.text
        assert r.headers["content-type"] == "application/json"
    assert _counts(settings) == (1, 0)
    assert c.post(url, json={"trial": 1, **MEASURED}).status_code == 201  # max_trials 1: finished
    r = c.post(url, json={"trial": 1, **MEASURED})
    assert (r.status_code, _field(r)) == (409, ["trial"]) and "already stored" in r.json()["detail"]
    r = c.post(url, json={"trial": 2, **MEASURED})
    assert (r.status_code, _field(r)) == (409, ["status"]) and "finished" in r.json()["detail"]
    assert _counts(settings) == (1, 1)


def test_a_session_whose_map_was_deleted_says_so(served):
    client, jobs, _, settings = served
    c = client("alice")
    sid = c.post("/api/adaptations", json={"repertoires": [jobs["alice"]]}).json()["id"]
    assert c.delete(f"/api/jobs/{jobs['alice']}").status_code == 204
    for r in (c.get(f"/api/adaptations/{sid}"), c.post(f"/api/adaptations/{sid}/trials", json={"trial": 1, **MEASURED})):
        assert (r.status_code, _field(r)) == (410, ["repertoires.0"]), r.text
        assert "deleted" in r.json()["detail"]
    assert _counts(settings) == (1, 0)


def test_a_session_over_an_uploaded_robots_map_gets_that_robots_target(served):
    """POST /api/adaptations over a map of a robot alice uploaded: the route hands the store
    the robot's loader, and the session's target is that robot's, measured on its model."""
    from app.adapt.recovered import target_speed
    from app.store import robots as robot_store

    gym = pytest.importorskip("gymnasium", reason="the test extra brings gymnasium")
    client, _, _, settings = served
    c = client("alice")
    path = Path(gym.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"
    r = c.post("/api/robots", files={"model": ("ant.xml", path.read_bytes(), "application/xml")}, data={"name": "ant"})
    assert r.status_code == 201, r.text
    rid = r.json()["id"]
    with session_scope(settings.db_url) as s:
        ant = robot_store.load_robot(s, settings.data_dir, rid)
        summary = json.loads(dumps(get_kind("repertoire").run(parse_spec(SPEC | {"robot": rid}),
                                                              MemoryContext(robots=lambda _: ant)).summary))
        job = repo.create_job(s, owner="alice", kind="repertoire", robot=rid, spec=SPEC | {"robot": rid},
                              evaluations_budget=1, max_attempts=3)
        job.status, job.summary, job.finished_at = "succeeded", summary, utcnow()
        jid = job.id
    r = c.post("/api/adaptations", json={"repertoires": [jid]})
    assert r.status_code == 201, r.text
    assert r.json()["target_m_s"] == pytest.approx(target_speed(rid, ant), rel=1e-12)
    assert r.json()["target_m_s"] > target_speed("jethexa")

"""/api/robots (issue 23): upload a third-party legged MJCF (files or one zip), list it
beside the built-ins, get and delete it as its owner only; every hostile upload is a 4xx
naming what was refused, with nothing stored and nothing of the host in any answer, and
the server stays up and within a stated memory bound throughout."""

from __future__ import annotations

import json
import resource
import sys
import uuid
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated

sys.path.insert(0, str(Path(__file__).parents[1] / "robots"))
import hostile_cases as hc  # noqa: E402
import legged_models as lm_  # noqa: E402

from app.api import create_app  # noqa: E402
from app.results import observed  # noqa: E402
from app.store import repo  # noqa: E402
from app.store import robots as store  # noqa: E402
from app.store.db import session_scope  # noqa: E402

# The API process may grow by at most this much over the whole hostile suite (the compiles
# run in their own processes, each confined to GAITMEND's 1 GiB compile address space).
MEMORY_BOUND_MB = 200


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path))


@pytest.fixture
def client(settings):
    return TestClient(create_app(settings))


def _tokens(settings, *names):
    with session_scope(settings.db_url) as s:
        return [{"Authorization": f"Bearer {repo.create_token(s, n)}"} for n in names]


def _stored(settings) -> tuple[int, list]:
    with session_scope(settings.db_url, readonly=True) as s:
        n = len(store.list_robots(s))
    folder = settings.data_dir / "robots"
    return n, sorted(folder.iterdir()) if folder.exists() else []


def _ant() -> bytes:
    path = lm_.gymnasium_ant()
    if path is None:
        pytest.skip("gymnasium is not installed (the test extra brings it)")
    return path.read_bytes()


def test_upload_list_get_delete_a_third_party_robot(client, settings):
    r = client.post("/api/robots", files={"model": ("ant.xml", _ant(), "application/xml")}, data={"name": "gym ant"})
    assert r.status_code == 201, r.text
    robot = r.json()
    assert robot["name"] == "gym ant" and robot["detected"] and len(robot["legs"]["legs"]) == 4
    # a job of either kind names it by its id (tests/robots/test_user_recovery.py, tests/jobs/repertoire)
    assert robot["kinds"] == ["recovery", "repertoire"]
    again = client.post("/api/robots", files={"model": ("ant.xml", _ant(), "application/xml")}, data={"name": "gym ant"})
    assert again.status_code == 200 and again.json()["id"] == robot["id"]
    listed = client.get("/api/robots").json()
    assert [x["name"] for x in listed if x.get("builtin")][:1] == ["jethexa"]  # built-ins first, as before
    assert [x["id"] for x in listed if not x.get("builtin")] == [robot["id"]]
    assert client.get(f"/api/robots/{robot['id']}").json()["legs"] == robot["legs"]
    assert client.get("/api/robots/jethexa").json()["kinds"] == ["recovery", "repertoire"]
    assert client.delete(f"/api/robots/{robot['id']}").status_code == 204
    assert client.get(f"/api/robots/{robot['id']}").status_code == 404
    assert _stored(settings) == (0, [])


def test_upload_as_a_zip_with_includes_and_a_given_leg_map(client):
    path = lm_.dm_control_quadruped()
    if path is None:
        pytest.skip("dm_control is not installed (the test extra brings it)")
    entries = [("quadruped/quadruped.xml", path.read_bytes())]
    entries += [(f"quadruped/common/{f.name}", f.read_bytes()) for f in (path.parent / "common").glob("*.xml")]
    first = client.post("/api/robots", files={"archive": ("q.zip", hc.zip_of(entries), "application/zip")})
    assert first.status_code == 201, first.text
    legs = first.json()["legs"]
    legs["legs"][0]["gains"] = {"kp": 80.0, "kd": 2.0}
    second = client.post("/api/robots", files={"archive": ("q.zip", hc.zip_of(entries), "application/zip")},
                         data={"legs": json.dumps(legs)})
    assert second.status_code == 201 and second.json()["id"] != first.json()["id"]  # a new leg map: a new robot
    assert not second.json()["detected"] and second.json()["legs"]["legs"][0]["gains"]["kp"] == 80.0


def test_a_robot_belongs_to_its_owner(settings):
    A, B = _tokens(settings, "alice", "bob")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    rid = client.post("/api/robots", files={"model": ("ant.xml", _ant())}, headers=A).json()["id"]
    for method in ("GET", "DELETE"):
        r = client.request(method, f"/api/robots/{rid}", headers=B)
        assert r.status_code == 404 and "no robot" in r.json()["detail"]
    assert rid not in [x.get("id") for x in client.get("/api/robots", headers=B).json()]
    assert rid in [x.get("id") for x in client.get("/api/robots", headers=A).json()]
    assert all(x.get("builtin") for x in client.get("/api/robots").json())  # no token: built-ins only
    assert client.post("/api/robots", files={"model": ("ant.xml", _ant())}).status_code == 401
    assert client.get(f"/api/robots/{rid}", headers=A).status_code == 200


def test_delete_is_refused_while_a_job_uses_the_robot(client, settings):
    rid = client.post("/api/robots", files={"model": ("ant.xml", _ant())}).json()["id"]
    with session_scope(settings.db_url) as s:
        job = repo.create_job(s, owner="local", kind="recovery", robot=rid, spec={"kind": "recovery"},
                              evaluations_budget=1, max_attempts=1)
        jid = job.id
    r = client.delete(f"/api/robots/{rid}")
    assert r.status_code == 409 and jid in r.json()["detail"]
    assert client.get(f"/api/robots/{rid}").status_code == 200


def _post(client, case: hc.Case, files: dict[str, bytes]):
    if case.archive is not None:
        return client.post("/api/robots", files={"archive": ("robot.zip", case.archive, "application/zip")})
    parts = [("model", ("model.xml", files["model.xml"], "application/xml"))]
    parts += [("assets", (k, v, "application/octet-stream")) for k, v in files.items() if k != "model.xml"]
    return client.post("/api/robots", files=parts)


def test_the_hostile_suite_gets_4xx_nothing_stored_nothing_read(client, settings, tmp_path):
    marker = f"GAITMEND-SECRET-{uuid.uuid4().hex}"
    host = tmp_path / "host"
    host.mkdir()
    for ext in ("xml", "stl", "png", "skn", "dtd"):
        (host / f"secret.{ext}").write_text(f"<mujoco model='{marker}'/>" if ext == "xml" else marker)
    secret, missing = host / "secret", host / "absent"
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for case in hc.cases(host):
        r = _post(client, case, hc.fill(case.files, secret, missing))
        assert 400 <= r.status_code < 500, (case.name, r.status_code, r.text)
        assert case.expect.lower() in r.json()["detail"].lower() and marker not in r.text, (case.name, r.text)
        assert r.json()["errors"][0]["field"], case.name
        if case.host_path:
            other = _post(client, case, hc.fill(case.files, missing, missing))
            assert (r.status_code, r.text.replace(str(secret), "<P>")) == \
                (other.status_code, other.text.replace(str(missing), "<P>")), case.name
        assert client.get("/api/health").status_code == 200  # the server is still up
    assert _stored(settings) == (0, [])
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
    print(f"\nhostile suite: the API process's peak RSS grew by {grown_mb:.1f} MB")
    observed.record("robots.hostile_api_peak_rss_growth_mb", [grown_mb], {"cases": len(hc.cases(host)),
                                                                          "bound (MB)": MEMORY_BOUND_MB})
    assert grown_mb < MEMORY_BOUND_MB, f"the API process grew by {grown_mb:.0f} MB"


@pytest.mark.parametrize("headers, body, status, words", [
    ({"content-type": "application/json"}, b"{}", 415, "multipart"),
    ({"content-type": "multipart/form-data; boundary=x"}, b"--x\r\nnot a form", 400, ""),
    ({"content-type": "multipart/form-data; boundary=x"}, b"--x--\r\n", 422, "model"),
])
def test_malformed_requests(client, settings, headers, body, status, words):
    r = client.post("/api/robots", content=body, headers=headers)
    assert r.status_code == status, r.text
    assert words in r.text
    assert _stored(settings) == (0, [])


def test_an_oversized_upload_is_refused_before_it_is_read(client, settings):
    big = b"<mujoco>" + b" " * (40 * 1024 * 1024) + b"</mujoco>"
    r = client.post("/api/robots", files={"model": ("big.xml", big)})
    assert r.status_code == 413, r.text
    assert _stored(settings) == (0, [])


def test_a_recovery_job_on_an_uploaded_robot_runs_through_the_api_and_the_worker(settings):
    from app.service.runner import run_job

    A, B = _tokens(settings, "alice", "bob")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    robot = client.post("/api/robots", files={"model": ("ant.xml", _ant())}, headers=A).json()
    leg = robot["legs"]["legs"][0]
    spec = {"kind": "recovery", "robot": robot["id"], "search": {"population": 4, "generations": 1},
            "robot_damage": {"locked_joints": [{"leg": leg["name"], "joint": leg["joints"][-1], "angle_deg": 40.0}]},
            "sim": {"duration_s": 1.0}, "controls": {"random_search": False}, "robustness": {"cases": []}}
    other = client.post("/api/jobs", json=spec, headers=B)  # bob's answer is the one for a robot that is not there
    assert other.status_code == 422 and other.json()["errors"][0]["field"] == "robot" and robot["id"] in other.json()["detail"]
    bad = client.post("/api/jobs", json=spec | {"robot_damage": {"lost_legs": ["no_such_leg"]}}, headers=A)
    assert bad.status_code == 422 and bad.json()["errors"][0]["field"] == "robot_damage" and "no_such_leg" in bad.json()["detail"]
    # the dashboard's dry run answers the same, before it would ask to confirm a long job
    for path in ("/api/web/check", "/api/jobs"):
        lame = client.post(path, json=spec | {"robot_damage": {"lost_legs": [g["name"] for g in robot["legs"]["legs"][:3]]}},
                           headers=A)
        assert lame.status_code == 422 and lame.json()["errors"][0]["field"] == "robot_damage", (path, lame.text)
    not_hers = client.post("/api/web/check", json=spec, headers=B)
    assert not_hers.status_code == 422 and not_hers.json()["errors"][0]["field"] == "robot", not_hers.text
    assert client.post("/api/web/check", json=spec, headers=A).status_code == 200
    r = client.post("/api/jobs", json=spec, headers=A)
    assert r.status_code == 201, r.text
    jid = r.json()["id"]
    assert client.delete(f"/api/robots/{robot['id']}", headers=A).status_code == 409  # a queued job uses it
    status = run_job(settings, jid)  # the worker loads the stored, sanitised robot
    assert status == "succeeded", client.get(f"/api/jobs/{jid}", headers=A).json().get("error")
    job = client.get(f"/api/jobs/{jid}", headers=A).json()
    user = job["summary"]["uploaded_robot"]
    assert job["robot"] == robot["id"] and user["actuation"]["upload_had"] == {"motor (torque)": 8}
    assert leg["joints"][-1] not in user["actuation"]["gains"]
    assert client.get(f"/api/jobs/{jid}/bundle", headers=A).status_code == 200


def test_the_worker_runs_a_job_only_on_its_owners_robot(settings):
    from app.service.runner import run_job

    A, = _tokens(settings, "alice")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    rid = client.post("/api/robots", files={"model": ("ant.xml", _ant())}, headers=A).json()["id"]
    spec = {"kind": "recovery", "robot": rid, "search": {"population": 4, "generations": 1}, "sim": {"duration_s": 1.0}}
    with session_scope(settings.db_url) as s:  # queued past the API's check (as a study's point is)
        jid = repo.create_job(s, owner="bob", kind="recovery", robot=rid, spec=spec, evaluations_budget=1,
                              max_attempts=1).id
    assert run_job(settings, jid) == "failed"
    with session_scope(settings.db_url, readonly=True) as s:
        assert "no uploaded robot" in repo.get_job(s, jid).error

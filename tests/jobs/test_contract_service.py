"""The contract tests' own kind (tests/kinds/ballistic.py), registered only through
GAITMEND_EXTRA_KINDS, driven as a user drives any kind: `gaitmend run` in a subprocess,
the API, a real Celery worker process, the bundle, the job list and `gaitmend reproduce`.
Nothing in app/ names it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from service_support import Proc, deployment, job_row, migrated, wait_for

from app.jobs import registry

KINDS_DIR = str(Path(__file__).resolve().parents[1] / "kinds")
EXTRA = {"GAITMEND_EXTRA_KINDS": "ballistic:KIND"}
SPEC = {"kind": "ballistic", "target_m": 1.5, "search": {"population": 6, "generations": 2, "seed": 9}}


def _pythonpath() -> str:
    return os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), KINDS_DIR) if p)


@pytest.fixture
def registered():
    before = dict(registry.KINDS)
    registry._load_extra(EXTRA["GAITMEND_EXTRA_KINDS"])
    yield
    registry.KINDS.clear()
    registry.KINDS.update(before)


def gaitmend(*args, cwd=None):
    env = os.environ | EXTRA | {"PYTHONPATH": _pythonpath(), "COLUMNS": "200"}
    return subprocess.run([sys.executable, "-m", "app", *args], capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=300)


def test_gaitmend_run_and_reproduce_drive_a_kind_registered_outside_app(tmp_path):
    (tmp_path / "spec.json").write_text(json.dumps(SPEC))
    p = gaitmend("run", str(tmp_path / "spec.json"), "--out", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    assert "ball to 1.5 m" in p.stdout and "stopped: generations" in p.stdout  # the kind's own table
    bundle = next((tmp_path / "out").glob("*.zip"))
    with zipfile.ZipFile(bundle) as z:
        names = set(z.namelist())
        readme = z.read("README.md").decode()
    assert {"replay.viser", "plots/convergence.svg", "trajectories/best.npz", "history.csv"} <= names
    assert "Ball launched to a target distance" in readme
    bad = gaitmend("run", str(tmp_path / "bad.json"))
    assert bad.returncode == 2
    (tmp_path / "bad.json").write_text(json.dumps(SPEC | {"target_m": "far"}))
    bad = gaitmend("run", str(tmp_path / "bad.json"), "--out", str(tmp_path / "no"))
    assert bad.returncode == 2 and "target_m" in bad.stderr and not (tmp_path / "no").exists()
    rep = gaitmend("reproduce", "ballistic", "--population", "8")
    assert rep.returncode == 0 and "population 8" in rep.stdout


def test_the_api_and_a_worker_run_it_to_a_bundle(tmp_path, registered):
    env = deployment(tmp_path) | EXTRA | {"PYTHONPATH": _pythonpath()}
    settings = migrated({k: v for k, v in env.items() if k.startswith("GAITMEND_") and k != "GAITMEND_EXTRA_KINDS"})
    client = TestClient(__import__("app.api", fromlist=["create_app"]).create_app(settings))
    bad = client.post("/api/jobs", json=SPEC | {"search": {"population": 6, "generations": 2.5}})
    assert bad.status_code == 422 and bad.json()["errors"][0]["field"] == "search.generations"
    r = client.post("/api/jobs", json=SPEC)
    assert r.status_code == 201, r.text
    jid = r.json()["id"]
    assert r.json()["damage"] == "target 1.5 m"
    robots = {x["name"]: x for x in client.get("/api/robots").json()}
    assert robots["ball"]["kinds"] == ["ballistic"]
    w = Proc(["worker", "--loglevel", "INFO"], env, tmp_path / "worker.log")
    try:
        wait_for(lambda: job_row(settings, jid).status in ("succeeded", "failed", "cancelled"), 120,
                 "the ballistic job", proc=w)
    finally:
        w.kill9()
        w.stop()
    job = client.get(f"/api/jobs/{jid}").json()
    assert job["status"] == "succeeded", job["error"]
    assert [h["label"] for h in job["headline"]] == ["distance error", "rest position"]
    assert job["headline"][0]["better"] == "lower"
    assert job["progress"]["done"] == job["progress"]["total"] == 3
    listed = client.get("/api/jobs").json()["items"][0]
    assert listed["id"] == jid and listed["headline"] == job["headline"]
    hist = client.get(f"/api/jobs/{jid}/history").json()
    assert [row["generation"] for row in (hist["rows"] if isinstance(hist, dict) else hist)] == [0, 1, 2]
    blob = client.get(f"/api/jobs/{jid}/bundle")
    assert blob.status_code == 200
    (tmp_path / "b.zip").write_bytes(blob.content)
    with zipfile.ZipFile(tmp_path / "b.zip") as z:
        assert json.loads(z.read("manifest.json"))["kind"] == "ballistic"
        assert json.loads(z.read("result.json"))["best"] == job["summary"]["best"]

"""Studies end to end: validation of every point before anything is written, real worker
processes on Redis + PostgreSQL (kill -9 mid-study, cancel mid-study), and the local
`gaitmend study run` giving the served aggregate."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from fastapi.testclient import TestClient
from service_support import ENTRY, Proc, deployment, migrated, proc_env, wait_for
from sqlalchemy import func, select

from app.api import create_app
from app.store.db import session_scope
from app.store.models import Job, Study
from app.studies.aggregate import aggregate
from app.studies.spec import expand

BASE = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
        "search": {"population": 4, "generations": 2, "seed": 0}, "sim": {"duration_s": 1.0}}
REPORT = {"group_by": ["damage.lost_legs"], "metrics": ["best.metrics.y_f_m", "best.metrics.yaw_f_deg", "best.fitness"]}


def study(points=None, grid=None, **kw) -> dict:
    d = {"name": "t", "base": BASE, "report": REPORT} | kw
    if points is not None:
        d["points"] = points
    if grid is not None:
        d["grid"] = grid
    return d


def counts(settings) -> tuple[int, int]:
    with session_scope(settings.db_url, readonly=True) as s:
        return s.scalar(select(func.count()).select_from(Job)), s.scalar(select(func.count()).select_from(Study))


def test_grid_expands_and_names_the_bad_point_and_field():
    plan = expand(study(grid={"damage.lost_legs": "all_feasible_1_and_2", "search.seed": [0, 1]},
                        list_infeasible=True))
    assert len(plan.points) == 2 * 15 and {tuple(x["overrides"]["damage.lost_legs"]) for x in plan.infeasible} == {
        (1, 3), (1, 5), (3, 5), (2, 4), (2, 6), (4, 6)}
    from app.jobs.base import SpecError

    with pytest.raises(SpecError) as e:
        expand(study(points=[{"search.seed": 1}, {"search.population": 2.5}]))
    assert e.value.errors[0]["field"] == "points[1].search.population"
    with pytest.raises(SpecError) as e:  # infeasible only where the study asks for it to be listed
        expand(study(points=[{"damage.lost_legs": [1, 3]}]))
    assert e.value.errors[0]["field"] == "points[0].damage.lost_legs"
    with pytest.raises(SpecError) as e:
        expand(study(points=[{"search.seed": 1}], grid={"search.seed": [1]}))
    with pytest.raises(SpecError) as e:
        expand(study(grid={"search.seed": list(range(2000))}))
    assert "limit is" in e.value.errors[0]["message"]


def test_a_bad_point_rejects_the_whole_study_and_one_over_the_queue_limit_is_fed_gradually(tmp_path, pg_url):
    settings = migrated(deployment(tmp_path, database_url=pg_url, max_queued_per_owner=3))
    client = TestClient(create_app(settings))
    r = client.post("/api/studies", json=study(points=[{"search.seed": 1}, {"search.seed": 2},
                                                       {"search.population": 1}]))
    assert r.status_code == 422, r.text
    assert r.json()["errors"][0]["field"] == "points[2].search.population"
    assert counts(settings) == (0, 0)
    # more points than the owner may queue: accepted, and admitted to the queue gradually
    # (app/studies/fair.py: at most half the owner's limit at a time)
    r = client.post("/api/studies", json=study(grid={"search.seed": [0, 1, 2, 3]}))
    assert r.status_code == 201 and r.json()["progress"]["queued"] == 4, r.text
    with session_scope(settings.db_url, readonly=True) as s:
        assert sorted(j.held for j in s.scalars(select(Job))) == [False, True, True, True]
    assert client.post("/api/jobs", json=BASE).status_code == 201  # the owner's own jobs still fit
    # the built-in studies are all valid
    from app.studies.catalog import builtin_studies

    assert builtin_studies()
    for spec in builtin_studies().values():
        expand(spec)


@pytest.fixture
def workers(tmp_path):
    procs = []

    def start(env):
        p = Proc(["worker", "--loglevel", "INFO"], env, tmp_path / f"worker{len(procs)}.log")
        procs.append(p)
        return p

    yield start
    for p in procs:
        p.kill9()
        p.stop()


def _jobs(settings, sid):
    with session_scope(settings.db_url, readonly=True) as s:
        return list(s.scalars(select(Job).where(Job.study_id == sid).order_by(Job.study_point)))


def test_kill9_mid_study_every_point_once_and_local_run_gives_the_same_aggregate(tmp_path, redis_url, pg_url, workers):
    env = deployment(tmp_path, database_url=pg_url, broker=redis_url)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    spec = study(grid={"damage.lost_legs": [[1, 6], [4]], "search.seed": [0, 1]})
    r = client.post("/api/studies", json=spec)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    w1 = workers(env)
    # kill -9 while a point runs, once another has finished
    wait_for(lambda: any(j.status == "succeeded" for j in _jobs(settings, sid))
             and any(j.status == "running" for j in _jobs(settings, sid)), 120, "a point done and one running", proc=w1)
    w1.kill9()
    workers(env)
    st = wait_for(lambda: (x := client.get(f"/api/studies/{sid}").json())["status"] not in ("queued", "running") and x,
                  240, "the study to finish")
    assert st["status"] == "succeeded", st
    assert st["progress"] == {"points": 4, "done": 4, "running": 0, "queued": 0, "failed": 0, "cancelled": 0}
    jobs = _jobs(settings, sid)
    assert [j.study_point for j in jobs] == [0, 1, 2, 3] and all(j.status == "succeeded" for j in jobs)
    assert max(j.attempt for j in jobs) == 2  # the killed point ran again; no point was duplicated
    # the local command (all cores, no server) gives the same aggregate
    out = tmp_path / "local"
    (tmp_path / "s.json").write_text(json.dumps(spec))
    p = subprocess.run([sys.executable, "-c", ENTRY, "study", "run", str(tmp_path / "s.json"), "--out", str(out),
                        "--workers", "2", "--json"], env=proc_env({}), capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    local = json.loads(p.stdout.strip().splitlines()[-1])["aggregate"]
    assert local == st["aggregate"]
    assert len(st["aggregate"]["rows"]) == 2 and all(r["metrics"]["best.fitness"]["n"] == 2 for r in st["aggregate"]["rows"])
    # the study's page: the verdict over the seeds, the aggregate table, the damage atlas
    # from the points, one chart per reported metric
    panels = client.get(st["links"]["views"]).json()["panels"]
    assert [p["id"] for p in panels] == ["verdict", "aggregate", "atlas", "metric-0", "metric-1", "metric-2"]
    chart = panels[5]["figure"]["data"][0]  # best.fitness: median and range per damage
    fit = {tuple(r["group"][0]): r["metrics"]["best.fitness"] for r in st["aggregate"]["rows"]}
    assert chart["y"] == [fit[(1, 6)]["median"], fit[(4,)]["median"]]
    assert chart["error_y"]["array"][0] == pytest.approx(fit[(1, 6)]["max"] - fit[(1, 6)]["median"])
    atlas = panels[2]["figure"]
    assert sum(1 for t in atlas["data"] if t.get("fill") == "toself") == 2  # one hexapod per damage
    assert any("legs 1, 6 lost" in a["text"] for a in atlas["layout"]["annotations"])
    # the study bundle: aggregate, every summary, a manifest that reproduces the study
    import io
    import zipfile

    z = zipfile.ZipFile(io.BytesIO(client.get(f"/api/studies/{sid}/bundle").content))
    names = set(z.namelist())
    assert {"aggregate.csv", "aggregate.md", "manifest.json", "points/0003.json"} <= names
    man = json.loads(z.read("manifest.json"))
    assert expand(man["study"]).points == expand(spec).points
    assert (out / "aggregate.csv").read_text() == z.read("aggregate.csv").decode()


def test_cancel_mid_study_cancels_the_unfinished_points(tmp_path, redis_url, pg_url, workers):
    env = deployment(tmp_path, database_url=pg_url, broker=redis_url)
    settings = migrated(env)
    client = TestClient(create_app(settings))
    r = client.post("/api/studies", json=study(grid={"search.seed": [0, 1, 2, 3, 4]}))
    sid = r.json()["id"]
    w = workers(env)
    wait_for(lambda: any(j.status == "running" for j in _jobs(settings, sid)), 120, "a point running", proc=w)
    assert client.post(f"/api/studies/{sid}/cancel").status_code == 202
    st = wait_for(lambda: (x := client.get(f"/api/studies/{sid}").json())["status"] not in ("queued", "running") and x,
                  120, "the study to stop")
    assert st["status"] == "cancelled"
    jobs = _jobs(settings, sid)
    assert sum(j.status == "cancelled" for j in jobs) >= 4
    assert all(j.attempt == 0 for j in jobs if j.status == "cancelled" and j.started_at is None)
    assert {f["index"] for f in st["aggregate"]["failed"]} == {j.study_point for j in jobs if j.status == "cancelled"}


def test_a_study_reads_as_what_its_points_did_not_as_what_was_asked():
    """A cancel asked for once every point had finished cancelled nothing: 3 of 3 done is
    succeeded (the page said "cancelled" beside "3 of 3 done"); a point cancelled makes it
    cancelled, a failed one failed."""
    from app.studies.store import status_of

    assert status_of({"succeeded": 3}) == "succeeded"
    assert status_of({"succeeded": 2, "failed": 1}) == "failed"
    assert status_of({"succeeded": 2, "cancelled": 1}) == "cancelled"
    assert status_of({"succeeded": 1, "running": 1}) == "running"
    assert status_of({"queued": 3}) == "queued"


def test_fair_dispatch_another_owners_single_job_does_not_wait_for_a_whole_study(tmp_path, redis_url, pg_url, workers):
    """Policy (app/studies/fair.py): at most `window` messages per owner in the broker,
    refilled round robin. With one worker (window 2), bob's job submitted after alice's
    10-point study starts after at most a few of alice's points, not after all ten."""
    from app.store import repo

    env = deployment(tmp_path, database_url=pg_url, broker=redis_url)
    settings = migrated(env)
    with session_scope(settings.db_url) as s:
        alice, bob = repo.create_token(s, "alice"), repo.create_token(s, "bob")
    client = TestClient(create_app(settings, host="0.0.0.0"))
    A, B = ({"Authorization": f"Bearer {t}"} for t in (alice, bob))
    tiny = BASE | {"search": {"population": 4, "generations": 1, "seed": 0}, "sim": {"duration_s": 0.5}}
    r = client.post("/api/studies", json=study(grid={"search.seed": list(range(10))}, base=tiny), headers=A)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    r = client.post("/api/jobs", json=tiny, headers=B)
    jid = r.json()["id"]
    w = workers(env)
    wait_for(lambda: client.get(f"/api/jobs/{jid}", headers=B).json()["status"] == "succeeded", 240,
             "bob's job", proc=w)
    with session_scope(settings.db_url, readonly=True) as s:
        bob_start = repo.get_job(s, jid).started_at
    started_before = [j for j in _jobs(settings, sid) if j.started_at is not None and j.started_at < bob_start]
    assert len(started_before) <= 3, len(started_before)  # FIFO would have run all 10 first
    client.post(f"/api/studies/{sid}/cancel", headers=A)
    assert client.get(f"/api/studies/{sid}", headers=B).status_code == 404  # studies belong to their owner


def test_study_pages_and_builtin_specs_are_served(tmp_path):
    from app.jobs.registry import KINDS
    from app.studies.catalog import builtin_studies

    settings = migrated(deployment(tmp_path))
    client = TestClient(create_app(settings))
    spec = client.get("/api/studies/builtin/recovery_table2").json()
    assert len(expand(spec).points) == 40
    r = client.get("/api/studies/builtin/nope")
    assert r.status_code == 404 and r.json()["errors"][0]["field"] == "name", r.text
    # the list: every registered kind's studies, in registry order, each kind's paper table first
    items = client.get("/api/studies/builtin").json()["items"]
    assert [i["name"] for i in items] == list(builtin_studies())
    assert [i["name"] for i in items] == [n for k in KINDS.values() for n in k.builtin_studies()]
    assert {i["kind"] for i in items} == {k.name for k in KINDS.values() if k.builtin_studies()}
    for i in items:
        served = client.get(f"/api/studies/builtin/{i['name']}").json()
        assert served == builtin_studies()[i["name"]] and served["base"]["kind"] == i["kind"]
        assert i["title"] == served["name"]
    for path in ("/studies", "/studies/0123abcd"):
        r = client.get(path)
        assert r.status_code == 200 and "/static/studies.js" in r.text
    assert client.get("/static/studies.js").status_code == 200

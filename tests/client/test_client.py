"""gaitmend.Client against a real `gaitmend serve`: submit, wait, DataFrames, bundle,
studies, cancel / retry / delete, and errors that carry the API's field and message."""

from __future__ import annotations


import pandas as pd
import pytest

import gaitmend

SMOKE = {"kind": "recovery", "damage": {"lost_legs": [3, 4]},
         "search": {"population": 6, "generations": 2, "seed": 3}, "sim": {"duration_s": 1.0}}


def test_import_name_and_settings(monkeypatch, served):
    assert gaitmend.Client is __import__("app.client", fromlist=["Client"]).Client
    assert gaitmend.__version__
    monkeypatch.setenv("GAITMEND_SERVER", served[0] + "/")
    monkeypatch.setenv("GAITMEND_TOKEN", "gm_nothing")
    with gaitmend.Client() as c:  # the CLI's settings
        assert c.server == served[0] and c._http.headers["Authorization"] == "Bearer gm_nothing"


def test_submit_wait_summary_history_headline_bundle(client, finished, tmp_path):
    job = client.submit(SMOKE)
    assert job.status == "queued" and len(job.id) == 32
    assert job.wait(progress=True, timeout=300) is job and job.status == "succeeded"
    assert job.summary["best"]["metrics"]["y_f_m"] == pytest.approx(job.info["summary"]["best"]["metrics"]["y_f_m"])
    h = job.history
    assert isinstance(h, pd.DataFrame) and list(h["generation"]) == [0, 1, 2] and {"best", "mean"} <= set(h.columns)
    hl = job.headline
    assert list(hl.columns) == ["label", "value", "unit", "better", "target", "met"] and hl["label"][0]
    path = job.bundle(tmp_path)
    assert path == tmp_path / f"gaitmend-{job.id}.zip" and path.stat().st_size > 1000
    assert not list(tmp_path.glob("*.part"))
    b = job.open_bundle(tmp_path / "again.zip")
    assert b.job_id == job.id and b.summary["best"] == job.summary["best"]
    assert client.job(job.id[:8]).id == job.id  # a prefix, as the CLI takes


def test_jobs_frame_has_the_headline_columns_and_filters(client, finished):
    df = client.jobs(limit=None)
    assert {"id", "kind", "robot", "damage", "status", "done", "total", "created_at"} <= set(df.columns)
    assert set(finished) <= set(df["kind"])
    assert str(df["created_at"].dtype).startswith("datetime64")
    rec = client.jobs(kind="recovery", status="succeeded")
    assert set(rec["kind"]) == {"recovery"} and set(rec["status"]) == {"succeeded"}
    label = finished["recovery"].headline["label"][1]  # e.g. "forward distance"
    assert any(c.startswith(label) for c in rec.columns), rec.columns
    assert len(client.jobs(limit=2)) == 2
    assert client.jobs(robot="no-such-robot").empty


def test_errors_carry_the_api_field_and_message(client):
    with pytest.raises(gaitmend.InvalidSpec) as e:
        client.submit(SMOKE | {"search": {"population": 1}})
    assert e.value.status == 422 and e.value.field == "search.population"
    assert "4 <= population" in e.value.message and "search.population" in str(e.value)
    with pytest.raises(gaitmend.InvalidSpec) as e:
        client.submit(SMOKE | {"colour": "red", "sim": {"duration_s": -1}})
    assert {"colour", "sim.duration_s"} <= set(e.value.fields)
    with pytest.raises(gaitmend.NotFound) as e:
        client.job("0" * 32)
    assert e.value.status == 404 and e.value.field == "id"
    with pytest.raises(gaitmend.InvalidSpec) as e:
        client.jobs(status="sleeping")
    assert e.value.field.endswith("status")
    with pytest.raises(gaitmend.ServerUnreachable):
        gaitmend.Client("http://127.0.0.1:9", token="").job("x")


def test_cancel_retry_delete(client, finished, tmp_path):
    job = client.submit(SMOKE | {"search": {"population": 8, "generations": 300, "seed": 5}})
    job.cancel()
    assert job.wait(progress=False, timeout=120).status == "cancelled"
    with pytest.raises(gaitmend.Conflict) as e:
        job.bundle(tmp_path / "never")
    assert e.value.field == "status" and not (tmp_path / "never").exists()
    assert job.retry().status == "queued"
    job.cancel().wait(progress=False, timeout=120)
    job.delete()
    with pytest.raises(gaitmend.NotFound):
        job.refresh()
    with pytest.raises(gaitmend.Conflict):
        finished["recovery"].retry()  # a success is not retried


def test_study_results_one_row_per_point(client, finished):
    study = client.submit_study({"name": "client test", "base": SMOKE,
                                 "grid": {"damage.lost_legs": [[1, 6], [3, 4]], "search.seed": [0]},
                                 "report": {"group_by": ["damage.lost_legs"], "metrics": ["best.fitness"]}})
    assert study.wait(progress=False, timeout=300).status == "succeeded"
    res = study.results()
    assert list(res.columns) == ["index", "job_id", "status", "damage.lost_legs", "search.seed", "best.fitness",
                                 "held_out_kept", "held_out_n", "held_out_share", "held_out_fell", "fragile", "verdict",
                                 "error"]
    assert list(res["damage.lost_legs"]) == [(1, 6), (3, 4)] and (res["status"] == "succeeded").all()
    assert res["best.fitness"].notna().all()
    assert res.groupby("damage.lost_legs")["best.fitness"].max().shape == (2,)
    assert [j.id for j in study.jobs()] == list(res["job_id"])
    assert len(study.aggregate()) == 2
    assert study.id in set(client.studies()["id"])
    with pytest.raises(gaitmend.InvalidSpec) as e:
        client.submit_study({"name": "bad", "base": SMOKE, "grid": {"search.population": [1]},
                             "report": {"metrics": ["best.fitness"]}})
    assert "population" in str(e.value)


def test_a_job_read_is_one_request_on_one_kept_connection(client, finished):
    """What the client's cost per call stands for (its timing is a benchmark's business, not a
    unit test's): reading a job is one GET of /api/jobs/{id}, and 40 reads go over the one
    kept-alive connection, so a call costs the request and nothing more; the Job holds the
    server's JSON as a bare request reads it."""
    import gaitmend
    import httpx

    jid = finished["recovery"].id
    sent, connects = [], []

    def trace(event: str, info: dict) -> None:
        if event == "connection.connect_tcp.complete":
            connects.append(event)

    def on_request(request: httpx.Request) -> None:
        sent.append((request.method, request.url.path))
        request.extensions["trace"] = trace

    with gaitmend.Client(client.server, token="") as c:
        c._http.event_hooks["request"].append(on_request)
        jobs = [c.job(jid) for _ in range(40)]
    assert sent == [("GET", f"/api/jobs/{jid}")] * 40
    assert len(connects) == 1
    raw = httpx.get(f"{client.server}/api/jobs/{jid}").json()
    assert all(j.info == raw for j in jobs)

"""Adaptation sessions in the store (app/adapt/session.py, app/store/repo/adaptations.py) on
SQLite and PostgreSQL: created over finished repertoire jobs (real maps, built small here),
each trial posted once and in order, the proposals exactly those of the loop
(app/adapt/simulate.py) fed the same measurements, a finished session refusing more, every
refusal writing nothing, and a proposal's files for the robot."""

from __future__ import annotations

import csv
import dataclasses
import io
import json

import numpy as np
import pytest
from sqlalchemy import func, select

from app.adapt import methods as M
from app.adapt import session as S
from app.adapt.maps import read_repertoires
from app.adapt.reality import Measured
from app.adapt.simulate import run as run_loop
from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec
from app.store import repo
from app.store.adaptation_models import AdaptationRow, AdaptationTrial
from app.store.db import session_scope
from app.store.migrate import upgrade
from app.store.models import utcnow

SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 8, "checkpoint_every": 4},
        "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
        "evidence": {"rescore_elites": 0, "random_control": False}}
DISP = {"type": "displacement", "forward_m": [-0.3, 0.3], "lateral_m": [-0.3, 0.3]}


@pytest.fixture(scope="module")
def summaries():
    """Three small maps: ITE's contact descriptor, and two over displacement (intact, lost leg1)."""
    def build(extra):
        spec = parse_spec(SPEC | extra)
        return json.loads(dumps(get_kind("repertoire").run(spec, MemoryContext()).summary))

    return {"contact": build({}), "disp": build({"descriptor": DISP}),
            "disp_lost": build({"descriptor": DISP, "damage": {"lost_legs": ["leg1"]}})}


def _job(s, owner, summary, kind="repertoire", status="succeeded", robot="jethexa"):
    job = repo.create_job(s, owner=owner, kind=kind, robot=robot, spec=dict(SPEC, robot=robot), evaluations_budget=1,
                          max_attempts=3)
    job.status, job.summary, job.finished_at = status, summary, utcnow()
    return job.id


@pytest.fixture
def db(database_url):
    upgrade(database_url)
    return database_url


def _measure(k: int) -> dict:
    """The lab's k-th measurement (made up, varied, backwards: below any prediction, no early stop)."""
    return {"forward_m": -0.002 * k - 0.001, "lateral_m": 0.01 * (-1) ** k, "yaw_deg": 3.0 * k, "fell": k == 3,
            "duration_s": 1.0}


def _counts(url):
    with session_scope(url, readonly=True) as s:
        return (s.scalar(select(func.count()).select_from(AdaptationRow)),
                s.scalar(select(func.count()).select_from(AdaptationTrial)))


def test_a_session_proposes_what_the_loop_proposes(db, summaries, tmp_path):
    with session_scope(db) as s:
        ids = [_job(s, "alice", summaries["disp"]), _job(s, "alice", summaries["disp_lost"])]
        row = repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": ids, "method": "gaitmend",
                                                             "stop": {"max_trials": 6, "alpha": 1.0}}),
                                     owner="alice", owner_filter="alice")
        sid = row.id
        first = repo.adaptation_json(s, row)
    assert first["status"] == "open" and first["trials"] == [] and first["decision"]["stop"] is False
    assert [m["job"] for m in first["maps"]] == ids and first["trial_s"] == 1.0
    got, k = [first["next"]], 0
    while True:
        k += 1
        with session_scope(db) as s:
            out = repo.adaptation_json(s, repo.post_trial(s, sid, S.TrialIn.parse({"trial": k, **_measure(k)}),
                                                           owner="alice"))
        if out["next"] is None:
            break
        got.append(out["next"])
    assert out["status"] == "finished" and k == 6 and out["decision"]["stop"]
    assert out["stop_reason"] == out["decision"]["reason"] and "6 trials spent" in out["stop_reason"]
    assert [t["trial"] for t in out["trials"]] == list(range(1, 7))
    assert out["trials"][2]["fell"] is True and out["trials"][2]["performance_m_s"] == 0.0  # falls count 0

    # the reference: the loop of app/adapt/simulate.py over the same maps, fed the same measurements
    paths = []
    for n, key in enumerate(("disp", "disp_lost")):
        p = tmp_path / f"{n}.json"
        p.write_text(json.dumps(summaries[key]))
        paths.append(p)
    reps = read_repertoires(paths)
    seen = iter(range(1, 100))

    def measure(rep, p):
        m = _measure(next(seen))
        return Measured(m["forward_m"], m["lateral_m"], m["yaw_deg"], m["fell"], m["duration_s"])

    ref = run_loop(reps, measure, dataclasses.replace(M.GAITMEND, alpha=1.0, max_trials=6), None)
    assert [(g["map"], g["elite"]) for g in got] == [(r.proposal.map, r.proposal.elite) for r in ref.rows]
    assert [g["predicted_m_s"] for g in got] == pytest.approx([r.proposal.predicted for r in ref.rows], abs=1e-12)
    assert [(t["map"], t["elite"]) for t in out["trials"]] == [(g["map"], g["elite"]) for g in got]
    assert out["decision"]["reason"] == ref.decision.reason
    assert got[0]["params"] == [float(v) for v in reps[0].params[got[0]["elite"]]] or got[0]["map"] != reps[0].map.name


def test_trials_are_posted_once_in_order_and_refusals_write_nothing(db, summaries):
    with session_scope(db) as s:
        jid = _job(s, "alice", summaries["contact"])
        sid = repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [jid], "stop": {"max_trials": 2}}),
                                     owner="alice", owner_filter="alice").id

    def post(n, owner="alice", **kw):
        with session_scope(db) as s:
            return repo.post_trial(s, sid, S.TrialIn.parse({"trial": n, **_measure(n), **kw}), owner=owner).status

    with pytest.raises(repo.Conflict) as e:
        post(2)
    assert e.value.field == "trial" and "next is trial 1" in str(e.value)
    assert _counts(db) == (1, 0)
    with pytest.raises(repo.NotFound):  # another owner's session is missing, as a job
        post(1, owner="bob")
    assert post(1) == "open"
    with pytest.raises(repo.Conflict) as e:
        post(1)
    assert e.value.field == "trial" and "already stored" in str(e.value)
    assert _counts(db) == (1, 1)
    assert post(2) == "finished"
    with pytest.raises(repo.Conflict) as e:
        post(3)
    assert e.value.field == "status" and "finished" in str(e.value)
    with pytest.raises(repo.Conflict) as e:  # a repeat of the last trial says it is a repeat
        post(2)
    assert e.value.field == "trial"
    assert _counts(db) == (1, 2)
    with session_scope(db, readonly=True) as s:
        rows = repo.trial_rows(s, repo.get_adaptation(s, sid))
        assert [(r.index, r.forward_m, r.fell) for r in rows] == [(1, -0.003, False), (2, -0.005, False)]


def test_a_session_needs_the_owners_finished_repertoires(db, summaries):
    with session_scope(db) as s:
        mine = _job(s, "alice", summaries["contact"])
        theirs = _job(s, "bob", summaries["contact"])
        running = _job(s, "alice", None, status="running")
        recovery = _job(s, "alice", {"best": {}}, kind="recovery")
        disp = _job(s, "alice", summaries["disp"])
    cases = [([mine, theirs], 404, "repertoires.1"), ([running], 409, "repertoires.0"),
             ([recovery], 422, "repertoires.0"), ([mine, disp], 422, "repertoires"),
             (["0" * 32], 404, "repertoires.0")]
    for ids, status, field in cases:
        with pytest.raises(repo.Refused) as e:
            with session_scope(db) as s:
                repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": ids}), owner="alice",
                                       owner_filter="alice")
        assert (e.value.status, e.value.field) == (status, field), str(e.value)
    assert "repertoire job" in str(e.value) or "no job" in str(e.value)
    assert _counts(db) == (0, 0)
    with session_scope(db) as s:  # an unrestricted caller (no auth) may use anyone's
        repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [theirs]}), owner="local", owner_filter=None)
    assert _counts(db) == (1, 0)


@pytest.mark.parametrize("data, field", [
    ({"trial": 1, "forward_m": float("nan")}, "forward_m"),
    ({"trial": 1, "forward_m": float("inf")}, "forward_m"),
    ({"trial": 1, "forward_m": "0.1"}, "forward_m"),
    ({"trial": 1, "fell": "no"}, "fell"),
    ({"trial": 1, "duration_s": 0.0}, "duration_s"),
    ({"trial": 1, "yaw_deg": 1e6}, "yaw_deg"),
    ({"trial": 0}, "trial"),
    ({"trial": 1, "note": "x" * 501}, "note"),
    ({"trial": 1, "speed": 1.0}, "speed"),
    ({"trial": 1.5}, "trial"), ({"trial": "1"}, "trial"), ({"trial": True}, "trial"),
])
def test_a_bad_trial_names_its_field(data, field):
    body = {"forward_m": 0.1, "lateral_m": 0.0, "yaw_deg": 0.0, "fell": False, "duration_s": 1.0} | data
    with pytest.raises(SpecError) as e:
        S.TrialIn.parse(body)
    assert field in [x["field"] for x in e.value.errors], e.value.errors


@pytest.mark.parametrize("data, field", [
    ({"repertoires": []}, "repertoires"), ({"repertoires": ["a" * 32, "a" * 32]}, "repertoires"),
    ({"repertoires": ["nope"]}, "repertoires.0"), ({"repertoires": ["a" * 32], "method": "bo"}, "method"),
    ({"repertoires": ["a" * 32], "stop": {"alpha": 1.5}}, "stop.alpha"),
    ({"repertoires": ["a" * 32], "stop": {"max_trials": 101}}, "stop.max_trials"),
    ({"repertoires": ["a" * 32], "trial_s": -1.0}, "trial_s"), ({"repertoires": ["a" * 32], "x": 1}, "x"),
])
def test_a_bad_session_names_its_field(data, field):
    assert S.SessionSpec.parse({"repertoires": ["a" * 32], "stop": {"max_trials": 7.0}}).stop.max_trials == 7
    with pytest.raises(SpecError) as e:
        S.SessionSpec.parse(data)
    assert field in [x["field"] for x in e.value.errors], e.value.errors


def test_a_proposal_is_the_repertoires_controller_and_its_setpoints(db, summaries):
    with session_scope(db) as s:
        jid = _job(s, "alice", summaries["contact"])
        sid = repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [jid], "trial_s": 0.5}), owner="alice",
                                     owner_filter="alice").id
    with session_scope(db, readonly=True) as s:
        nxt = repo.adaptation_json(s, repo.get_adaptation(s, sid))["next"]
        files = repo.proposal_bundle(s, sid, 1)
        with pytest.raises(repo.Refused) as e:
            repo.proposal_bundle(s, sid, 2)
        assert e.value.field == "trial"
    from app.jobs.base import JobResult

    kind_files = get_kind("repertoire").bundle_files(None, JobResult(summaries["contact"], [], {}, "", 0, 0))
    assert files["controller/repertoire_controller.py"].decode() == kind_files["controller/repertoire_controller.py"]
    assert files["controller/layout.json"].decode() == kind_files["controller/layout.json"]
    gait = json.loads(files["gait.json"])
    assert gait == nxt and gait["params"] == summaries["contact"]["elites"]["solution"][gait["elite"]]
    rows = list(csv.reader(io.StringIO(files["setpoints.csv"].decode())))
    layout = json.loads(kind_files["controller/layout.json"])
    assert rows[0] == ["t_s", *layout["joints"]] and len(rows) == 1 + 51  # 0 .. 0.5 s at 100 Hz
    # the set-points by the formula of the controller's docstring, written out here
    x = np.asarray(gait["params"])
    n = len(layout["joints"])
    lo, hi, st = (np.asarray(layout[k]) for k in ("lo", "hi", "stance"))
    half = 0.5 * (hi - lo)
    t = 0.37
    amp, ph, off = x[0:3 * n:3] * layout["amplitude"] * half, x[1:3 * n:3], st + (2 * x[2:3 * n:3] - 1) * \
        layout["offset"] * half
    period = layout["period_s"][0] + x[3 * n] * (layout["period_s"][1] - layout["period_s"][0])
    w = min(1.0, t / layout["ramp_s"]) if layout["ramp_s"] > 0 else 1.0
    q = np.clip(st + w * (off - st + amp * np.sin(2 * np.pi * (t / period + ph))), lo, hi)
    assert [float(v) for v in rows[1 + 37][1:]] == pytest.approx(q, abs=1e-9)


def test_the_same_trial_posted_twice_at_once_is_stored_once(db, summaries):
    """Two requests racing with trial 1 (a lab's retry while the first is under way): the
    session row is locked for the post, so one is stored and the other is told it is a repeat."""
    import threading

    with session_scope(db) as s:
        jid = _job(s, "alice", summaries["contact"])
        sid = repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [jid]}), owner="alice",
                                     owner_filter="alice").id
    go, out = threading.Barrier(2), []

    def post():
        go.wait()
        try:
            with session_scope(db) as s:
                repo.post_trial(s, sid, S.TrialIn.parse({"trial": 1, **_measure(1)}), owner="alice")
            out.append("stored")
        except repo.Conflict as e:
            out.append(e.field)

    threads = [threading.Thread(target=post) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert sorted(out) == ["stored", "trial"]
    assert _counts(db) == (1, 1)


def test_a_session_over_an_uploaded_robots_map_judges_trials_by_that_robots_target(db):
    """The target is fixed when the session is created, measured on the stored model (the
    Gymnasium ant, prepared as an upload is): a trial at that speed recovers, one just below
    does not; without the robot at hand the target stays null and so does `recovered`."""
    from app.adapt.recovered import target_speed
    from app.robots.upload.samples import sample_robot

    rid, ant = sample_robot("gym_ant")
    summary = json.loads(dumps(get_kind("repertoire").run(parse_spec(SPEC | {"robot": rid}),
                                                          MemoryContext(robots=lambda _: ant)).summary))
    want = target_speed(rid, ant)
    assert want > target_speed("jethexa")  # the ant's legs are longer than the hexapod's
    with session_scope(db) as s:
        jid = _job(s, "alice", summary, robot=rid)
        sids = [repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [jid]}), owner="alice",
                                       owner_filter="alice", robots=lambda _: ant).id for _ in range(2)]
        blind = repo.create_adaptation(s, S.SessionSpec.parse({"repertoires": [jid]}), owner="alice",
                                       owner_filter="alice").id
    for sid, speed in zip(sids, (want * 1.01, want * 0.99)):  # one trial each: the first may stop a session
        with session_scope(db) as s:
            repo.post_trial(s, sid, S.TrialIn.parse({"trial": 1, "forward_m": speed, "lateral_m": 0.0, "yaw_deg": 0.0,
                                                     "fell": False, "duration_s": 1.0}), owner="alice")
    with session_scope(db, readonly=True) as s:
        out = [repo.adaptation_json(s, repo.get_adaptation(s, sid)) for sid in sids]
        assert [o["target_m_s"] for o in out] == [pytest.approx(want, rel=1e-12)] * 2
        assert [o["trials"][0]["recovered"] for o in out] == [True, False]
        assert repo.adaptation_json(s, repo.get_adaptation(s, blind))["target_m_s"] is None

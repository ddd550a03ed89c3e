"""What the repertoire's page is given: the map in 2-D slices (every elite once per slice,
at its descriptor, coloured by its forward distance), the elites picked for a replay (the
best half, then each the furthest from those picked: checked against a brute-force
reference) with a trace each that the replay styles after the best gait, and a study of
islands' merged map."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from app.jobs.base import MemoryContext, dumps
from app.jobs.registry import get_kind, parse_spec
from app.jobs.repertoire import merge as mg
from app.jobs.repertoire.play import REPLAYS, replay_cells
from app.jobs.repertoire.views import study_views, views

KIND = get_kind("repertoire")
SPEC = {"kind": "repertoire", "seed": 9, "archive": {"cells": 40},
        "search": {"iterations": 4, "batch_size": 10, "checkpoint_every": 4},
        "sim": {"duration_s": 0.4, "settle_s": 0.05, "timestep_s": 0.002}, "evidence": {"rescore_elites": 0}}


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    return KIND.run(parse_spec(SPEC), MemoryContext(tmp_path_factory.mktemp("run")))


def test_replay_cells_best_half_then_farthest_points():
    rng = np.random.default_rng(0)
    n, k = 40, 8
    cells = rng.permutation(200)[:n]
    obj = rng.normal(size=n)
    meas = rng.uniform(size=(n, 3))
    got = replay_cells(cells, obj, meas, [(0, 1)] * 3, k)
    best = [int(cells[i]) for i in np.argsort(-obj)[:k // 2]]
    assert got[:k // 2] == best and len(set(got)) == k
    picked = [int(np.flatnonzero(cells == c)[0]) for c in best]
    for c in got[k // 2:]:  # the reference: the remaining elite furthest from every one picked
        d = [min(np.linalg.norm(meas[i] - meas[j]) for j in picked) for i in range(n)]
        assert c == int(cells[int(np.argmax(d))])
        picked.append(int(np.flatnonzero(cells == c)[0]))
    # a map no bigger than k: every elite, furthest walker first
    assert replay_cells(cells[:5], obj[:5], meas[:5], [(0, 1)] * 3, k) == [int(cells[i]) for i in np.argsort(-obj[:5])]
    # the bounds' units: a dimension twice as wide counts half as much
    scaled = replay_cells(cells, obj, meas * [2, 1, 1], [(0, 2), (0, 1), (0, 1)], k)
    assert scaled == got


def test_the_job_records_the_picked_elites_and_the_page_rings_them(result):
    s = json.loads(dumps(result.summary))
    e = s["elites"]
    names = [n for n in result.traces if n.startswith("elite_")]
    want = replay_cells(e["cell"], e["objective"], e["measures"], s["descriptor"]["bounds"])
    assert names == [f"elite_{c}" for c in want] and len(names) == min(len(e["cell"]), REPLAYS)
    row = {c: i for i, c in enumerate(e["cell"])}
    for c in want[:2]:  # each trace is that elite's walk: the same centre-of-mass path as the search scored
        tr = result.traces[f"elite_{c}"]
        assert "qpos" in tr and tr["time_s"][1] - tr["time_s"][0] == pytest.approx(0.02)
    tracks = KIND.replay_style(list(result.traces))
    assert tracks[0].name == "best" and sorted(t.name for t in tracks[1:]) == sorted(names)
    assert all(t.label == f"elite of cell {t.name[6:]}" for t in tracks[1:])

    panels = {p["id"]: p for p in views(s, result.traces)}
    data = panels["map"]["figure"]["data"]
    dots = [t for t in data if t["name"] == "elites"]
    rings = [t for t in data if t["name"] == "has a replay"]
    dims = len(s["descriptor"]["names"])
    assert len(dots) == len(rings) == (dims + 1) // 2
    for k, (t, r) in enumerate(zip(dots, rings)):
        i, j = (2 * k, 2 * k + 1) if 2 * k + 1 < dims else (dims - 1, 0)
        for text, x, y, c in zip(t["text"], t["x"], t["y"], t["marker"]["color"]):
            q = row[int(text[5:])]
            assert (x, y, c) == pytest.approx((e["measures"][q][i], e["measures"][q][j], e["objective"][q]), abs=1e-5)
        assert sorted(t["text"]) == sorted(f"cell {c}" for c in e["cell"])
        assert sorted(int(x.split(":")[0][5:]) for x in r["text"]) == sorted(want)
    assert len(panels["replays"]["table"]["rows"]) == len(want)
    assert [r[0] for r in panels["replays"]["table"]["rows"]][0] == f"elite of cell {want[0]}"  # the best first
    no_traces = {p["id"] for p in views(s, {})}
    assert "replays" not in no_traces and "map" in no_traces


def test_a_study_of_islands_shows_the_merged_map():
    base = SPEC | {"evidence": {"rescore_elites": 0, "random_control": False}}
    study = mg.islands_study(base, 2)
    from app.studies.local import run_point
    from app.studies.spec import expand

    points = []
    for p in expand(study).points:
        status, summary, err = run_point(p["spec"])
        points.append({"index": p["index"], "overrides": p["overrides"], "spec": p["spec"], "status": status,
                       "summary": summary, "error": err})
    panels = {p["id"]: p for p in study_views(study, points)}
    merged = mg.merged_summary(study["base"], {p["index"]: p["summary"] for p in points})
    assert set(panels) == {"merged_map", "islands"}
    rows = panels["islands"]["table"]["rows"]
    assert [r[0] for r in rows] == ["island 0", "island 1", "merged"]
    assert rows[-1][2] == merged["archive"]["elites"] and rows[-1][4]["value"] == merged["archive"]["qd_score"]
    dots = next(t for t in panels["merged_map"]["figure"]["data"] if t["name"] == "elites")
    assert sorted(dots["text"]) == sorted(f"cell {c}" for c in merged["elites"]["cell"])
    assert "2 of 2 islands merged" in panels["merged_map"]["caption"]
    # one island still running: merged so far; the same panels in any order of the points
    partial = [dict(points[1], status="running", summary=None), points[0]]
    assert "1 of 2 islands merged so far" in {p["id"]: p for p in study_views(study, partial)}["merged_map"]["caption"]
    for order in itertools.permutations(points):
        assert study_views(study, list(order)) == study_views(study, points)
    # a repertoire study that is not islands of its base: nothing of the kind's own
    other = dict(study, points=[{"seed": 1, "search.iterations": 2}, {"seed": 2, "search.iterations": 2}])
    assert study_views(other, [dict(p, overrides=o) for p, o in zip(points, other["points"])]) == []

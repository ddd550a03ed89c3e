"""Islands merged into one map: the same merged archive whatever order the islands finish
in; each merged cell holds the furthest-walking of the islands' elites whose descriptor
falls in it (a slow reference over every elite); the islands study expands into valid
points whose budgets add up to the base spec's."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from app.jobs.repertoire import merge as mg
from app.studies.local import run_point
from app.studies.spec import expand

BASE = {"kind": "repertoire", "seed": 11, "archive": {"cells": 25},
        "search": {"iterations": 5, "batch_size": 6, "checkpoint_every": 5},
        "sim": {"duration_s": 0.3, "settle_s": 0.05, "timestep_s": 0.002},
        "evidence": {"rescore_elites": 0, "random_control": False}}


@pytest.fixture(scope="module")
def islands():
    """Three real islands, each run as a worker runs a study point (the summary's JSON round trip)."""
    plan = expand(mg.islands_study(BASE, 3))
    out = {}
    for p in plan.points:
        status, summary, error = run_point(p["spec"])
        assert status == "succeeded", error
        out[p["index"]] = summary
    return plan, out


def test_the_study_splits_the_budget_and_derives_seeds(islands):
    plan, _ = islands
    assert [p["overrides"]["search.iterations"] for p in plan.points] == [2, 2, 1]
    seeds = [p["spec"]["seed"] for p in plan.points]
    assert seeds == [mg.island_seed(11, i) for i in range(3)] and len(set(seeds)) == 3 and 11 not in seeds
    assert all(0 <= s <= 2**31 - 1 for s in seeds)
    assert sum(p["spec"]["search"]["iterations"] for p in plan.points) == BASE["search"]["iterations"]
    assert {p["spec"]["archive"]["centroid_seed"] for p in plan.points} == {11}  # the base's cells, every island
    assert mg.shares(7, 7) == [1] * 7 and mg.shares(10, 4) == [3, 3, 2, 2]
    with pytest.raises(ValueError, match="islands"):
        mg.shares(3, 4)


def test_merged_archive_is_the_same_whatever_order_islands_finish(islands):
    _, summaries = islands
    first = mg.merge(BASE, summaries)
    assert not first.empty
    for order in itertools.permutations(summaries):
        again = mg.merge(BASE, [(i, summaries[i]) for i in order])
        assert mg.same_archive(first, again), order
    # and a dict built in another order
    assert mg.same_archive(first, mg.merge(BASE, {i: summaries[i] for i in reversed(list(summaries))}))


def test_each_merged_cell_holds_the_islands_best_elite_there(islands):
    _, summaries = islands
    merged = mg.merge(BASE, summaries)
    rows = [(s["elites"]["objective"][k], s["elites"]["measures"][k], s["elites"]["solution"][k])
            for s in summaries.values() for k in range(len(s["elites"]["cell"]))]
    cells = merged.index_of(np.array([m for _, m, _ in rows]))
    want: dict[int, float] = {}
    for (obj, _, _), c in zip(rows, cells):  # the slow reference: one elite at a time
        want[int(c)] = max(want.get(int(c), -np.inf), obj)
    data = merged.data()
    got = dict(zip(np.asarray(data["index"]).tolist(), np.asarray(data["objective"]).tolist()))
    assert got == want
    solutions = {tuple(x) for _, _, x in rows}
    assert all(tuple(x) in solutions for x in np.asarray(data["solution"]).tolist())
    s = mg.merged_summary(BASE, summaries)
    assert s["archive"]["elites"] == len(want) and s["evaluations"] == 5 * 6
    assert s["archive"]["best_forward_m"] == max(v["archive"]["best_forward_m"] for v in summaries.values())


def test_islands_on_the_base_cells_lose_no_elite(islands):
    """Every island fills the base spec's cells: the merged map holds every cell any island
    filled, each with the furthest-walking of their elites there."""
    _, summaries = islands
    data = mg.merge(BASE, summaries).data()
    got = dict(zip(np.asarray(data["index"]).tolist(), np.asarray(data["objective"]).tolist()))
    best: dict[int, float] = {}
    for s in summaries.values():
        for c, o in zip(s["elites"]["cell"], s["elites"]["objective"]):
            best[c] = max(best.get(c, -np.inf), o)
    assert got == best and len(got) >= max(len(s["elites"]["cell"]) for s in summaries.values())


def test_islands_of_different_specs_are_refused(islands):
    _, summaries = islands
    other = dict(summaries[1], archive=dict(summaries[1]["archive"], cells=26))
    with pytest.raises(ValueError, match="island 1's archive"):
        mg.merge(BASE, {0: summaries[0], 1: other})
    with pytest.raises(ValueError, match="twice"):
        mg.merge(BASE, [(0, summaries[0]), (0, summaries[1])])

"""The islands' built-in study is the islands of its base spec (so its page merges them),
and the islands measurement's docs section states its figures and the 32-worker
extrapolation from them, marked as one."""

from __future__ import annotations

import copy

from app.jobs.registry import get_kind
from app.jobs.repertoire import merge as mg
from app.jobs.repertoire.reproduce.islands import COMMAND, render
from app.studies.spec import expand


def test_the_builtin_islands_study_is_the_islands_of_its_base():
    study = get_kind("repertoire").builtin_studies()["repertoire_islands"]
    want = mg.islands_study(study["base"], 4)
    assert study["points"] == want["points"]
    plan = expand(study)
    assert [p["spec"]["search"]["iterations"] for p in plan.points] == [25] * 4
    assert {p["spec"]["archive"]["centroid_seed"] for p in plan.points} == {0}
    assert len({p["spec"]["seed"] for p in plan.points}) == 4


RUN = {"base": {"seed": 0, "archive": {"cells": 500}, "search": {"batch_size": 100}}, "islands": 2, "gaits": 1600,
       "island_iterations": [8, 8], "single": {"wall_s": 100.0, "gaits_per_s": 16.0, "elites": 80, "coverage": 0.16,
                                               "qd_score": 100.0, "best_forward_m": 1.0},
       "served": [{"workers": 1, "wall_s": 80.0, "gaits_per_s": 20.0, "merge_s": 0.5,
                   "merged": {"elites": 90, "coverage": 0.18, "qd_score": 90.0, "best_forward_m": 0.9}},
                  {"workers": 2, "wall_s": 50.0, "gaits_per_s": 32.0, "merge_s": 0.5,
                   "merged": {"elites": 90, "coverage": 0.18, "qd_score": 90.0, "best_forward_m": 0.9}}],
       "merged_identical": True, "date": "2026-12-05 14:00 UTC", "commit": "abc", "machine": "a CPU, 2 cores",
       "load_before": 1.0, "load_after": 2.0, "wall_s": 300.0}


def test_the_section_states_the_figures_and_the_extrapolation():
    text = render([{"command": COMMAND, "runs": [copy.deepcopy(RUN)]}])
    assert "| 2 islands, 2 workers (merged) | 50.0 | 32.00 | 2.00 | 90 | 18.0 % | 90.00 | 0.900 |" in text
    assert "identical (bit for bit)" in text
    assert "an extrapolation, not a measurement" in text
    assert "about 640 gaits/s" in text and "2 workers scored 32.0 gaits/s against 20.0 for 1 (1.60 x; the assumption says 2.00 x)" in text
    assert "0.90 of the single run's" in text and "not shown" in text
    assert render([None]).startswith("_Not measured yet")

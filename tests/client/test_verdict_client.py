"""The Python client says what the job page says (issue 46): ``Job.verdict`` and
``Job.summarise()`` lead with the held-out figure, and a fragile gait's sentence says so
first; ``Client.jobs()`` and ``Study.results()`` carry it as columns (held-out kept, its
share, falls, fragile, the sentence). Jobs that are fragile or robust by construction:
tests/verdict_support.py."""

from __future__ import annotations

import pytest
from verdict_support import FRAGILE, ROBUST


@pytest.fixture(scope="module")
def pair(client):
    jobs = {"fragile": client.submit(FRAGILE), "robust": client.submit(ROBUST)}
    for job in jobs.values():
        assert job.wait(progress=False, timeout=300).status == "succeeded", job.info.get("error")
    return jobs


def test_a_job_says_its_held_out_figure_and_fragile_first(pair):
    frag, rob = pair["fragile"].verdict, pair["robust"].verdict
    assert (frag["held_out"]["met"], frag["held_out"]["n"], frag["held_out"]["fragile"]) == (0, 20, True)
    assert pair["fragile"].summarise().startswith("Fragile: keeps the target on 0 of 20: do not take it to the robot")
    assert "0 of 20 held-out random models keep the target (95 % interval 0–16 %)" in pair["fragile"].summarise()
    assert rob["held_out"]["fragile"] is False and rob["held_out"]["share"] >= 0.8
    assert not pair["robust"].summarise().startswith("Fragile") and rob["held_out"]["text"] in pair["robust"].summarise()
    assert frag["sentence"] == pair["fragile"].summarise()  # the API's sentence, the job page's


def test_the_jobs_frame_has_the_held_out_columns(client, pair):
    df = client.jobs().set_index("id")
    for name, job in pair.items():
        row, held = df.loc[job.id], job.verdict["held_out"]
        assert (row["held_out_kept"], row["held_out_n"], row["held_out_fell"]) == (held["met"], held["n"], held["fell"])
        assert row["fragile"] == (name == "fragile") and row["verdict"] == job.summarise()
    assert df.loc[pair["fragile"].id, "held_out_share"] == 0.0


def test_a_study_frame_has_the_held_out_columns(client):
    study = client.submit_study({"name": "held-out columns", "base": FRAGILE, "grid": {"search.seed": [1, 2]},
                                 "report": {"metrics": ["best.fitness"]}})
    assert study.wait(progress=False, timeout=300).status == "succeeded"
    res = study.results()
    assert list(res["held_out_kept"]) == [0, 0] and list(res["held_out_n"]) == [20, 20]
    assert res["fragile"].all() and res["verdict"].str.startswith("Fragile: keeps the target on 0 of 20").all()

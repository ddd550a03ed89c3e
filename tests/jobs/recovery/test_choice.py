"""choice.mode robust (app/jobs/recovery/run.py ``choose``, spec.Choice): the answer is the
member of DE's final population that meets the target on the nominal model and keeps it on
the most of the choice's random models; every later phase judges that gait; a kill after
the search resumes to the same answer; the paper's default chooses the best F as before."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.registry import get_kind, parse_spec

sys.path.insert(0, str(Path(__file__).parents[1]))
from test_contract import Ctx  # noqa: E402  (the contract tests' kill-and-resume context)

KIND = get_kind("recovery")
SPEC = {"kind": "recovery", "damage": {"lost_legs": [3, 4]}, "control": {"mode": "closed_loop"},
        "search": {"population": 8, "generations": 3, "seed": 4}, "sim": {"duration_s": 3.0},
        "controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 4}}
ROBUST = SPEC | {"choice": {"mode": "robust", "models": 5}}


@pytest.fixture(scope="module")
def runs():
    return {name: KIND.run(parse_spec(s), MemoryContext()) for name, s in (("best", SPEC), ("robust", ROBUST))}


def test_the_robust_choice_picks_by_the_rule_and_every_later_phase_judges_its_gait(runs):
    best, robust = runs["best"].summary, runs["robust"].summary
    c = robust["choice"]
    assert best["choice"] is None and c["members"] == 8 and c["models"] == 5
    # the same search: its best F is the paper's answer, and the choice starts from it
    assert c["best_fitness"] == best["best"]["fitness"] and c["chosen_fitness"] == robust["best"]["fitness"]
    # seed 4: the best F keeps the target on 0 of the 5 models and falls on one; another member keeps it on all
    assert c["meeting_target_nominally"] and robust["best"]["target_met"] is True
    assert c["chosen"] != c["best_fitness_member"] and c["chosen_fitness"] < c["best_fitness"]
    assert (c["chosen_kept"], -c["chosen_fell"]) > (c["best_kept"], -c["best_fell"])
    # the held-out block walks the chosen gait: the paper's figures exactly when the choice is the best F
    same = c["chosen"] == c["best_fitness_member"]
    walked = [m["metrics"] for m in robust["robustness"]["held_out"]["models"]]
    assert (walked == [m["metrics"] for m in best["robustness"]["held_out"]["models"]]) == same
    assert runs["robust"].evaluations == runs["best"].evaluations + parse_spec(ROBUST).choice_walks
    assert runs["robust"].evaluations <= parse_spec(ROBUST).evaluations_budget


def test_a_kill_after_the_search_resumes_to_the_same_choice(runs):
    spec = parse_spec(ROBUST)
    ctx = Ctx(kill_after_saves=4)  # generations 0..3 checkpoint: the kill comes as the search ends
    with pytest.raises(KeyboardInterrupt):
        KIND.run(spec, ctx)
    again = KIND.run(spec, Ctx(ckpt=ctx.load_checkpoint()))
    a, b = json.loads(dumps(again.summary)), json.loads(dumps(runs["robust"].summary))
    a.pop("timing"), b.pop("timing")
    assert a == b


@pytest.mark.parametrize("extra, message", [
    ({"search": {"optimizer": "cmaes"}}, "choice.mode"),
    ({"choice": {"mode": "robust", "models": 0}}, "choice.models"),
    ({"choice": {"mode": "nominal"}}, "choice.mode"),
])
def test_a_bad_choice_names_its_field(extra, message):
    data = json.loads(json.dumps(ROBUST))
    for k, v in extra.items():
        data[k] = data.get(k, {}) | v
    with pytest.raises(SpecError) as e:
        parse_spec(data)
    assert message in str(e.value)


def test_the_paper_default_adds_no_walk():
    assert parse_spec({"kind": "recovery"}).choice_walks == 0
    assert parse_spec(ROBUST).choice_walks == 8 * 6
    assert np.isfinite(parse_spec(ROBUST).evaluations_budget)


def test_the_comparison_appends_each_job_and_tables_the_three_answers(tmp_path, monkeypatch):
    """`gaitmend reproduce recovery-choice` at the tests' size, on one damage: the robust job
    judges its choice and the same search's best F, the longer job its best F, all on the same
    held-out models; a second run skips both jobs."""
    from app.jobs.recovery.reproduce import choice_check as C

    monkeypatch.setattr(C, "SCENARIOS", ((3, 4),))
    p = C.ChoiceParams(seeds=1, population=4, generations=1, models=1, held_out=20, json_out=tmp_path / "c.json")
    logs: list[str] = []
    text = C.run_choice(p, logs.append)
    data = json.loads(p.json_out.read_text())
    runs = {r["result"]["job"]: r["result"] for r in data["runs"]}
    assert set(runs) == {"robust", "longer"} and runs["longer"]["generations"] == 1 + 1 + 1
    assert set(runs["robust"]["arms"]) == {"best", "robust"} and set(runs["longer"]["arms"]) == {"longer"}
    for arm in ("best", "robust"):
        assert runs["robust"]["arms"][arm]["judged"]["n"] == 20
    c = runs["robust"]["choice"]
    same = c["chosen"] == c["best_fitness_member"]
    assert (runs["robust"]["arms"]["best"]["params"] == runs["robust"]["arms"]["robust"]["params"]) == same
    assert "| 3 & 4 | 1 |" in text and "robust choice" in text
    again: list[str] = []
    assert C.run_choice(p, again.append) == text and len(json.loads(p.json_out.read_text())["runs"]) == 2

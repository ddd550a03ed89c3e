"""The randomised robust search (spec ``randomised``): reproducible (same seed, same numbers;
a resume from a checkpoint continues bit-identically), a new draw every generation and seed,
and its budget counted right (the parents' re-scoring included)."""

import copy

import numpy as np
import pytest

from app.jobs.recovery.present import headline
from app.jobs.recovery.randomised import draws_of
from app.jobs.recovery.robust import cvar
from app.jobs.recovery.run import run
from app.jobs.registry import parse_spec

from tests.jobs.recovery.test_recovery import Ctx

P, G, K = 4, 2, 2
TINY = {"kind": "recovery", "damage": {"lost_legs": [1, 6]}, "sim": {"duration_s": 1.0},
        "search": {"population": P, "generations": G, "seed": 5},
        "randomised": {"models": K, "aggregate": "cvar", "cvar_share": 0.5},
        "robustness": {"cases": [], "held_out": 0}}


def numbers(summary):
    s = copy.deepcopy(summary)
    s.pop("timing")
    return s


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    spec = parse_spec(TINY)
    return spec, run(spec, Ctx(tmp_path_factory.mktemp("r")))


def test_same_seed_same_numbers_and_resume_is_bit_identical(tiny, tmp_path):
    spec, res = tiny
    assert numbers(run(spec, Ctx(tmp_path)).summary) == numbers(res.summary)
    ctx = Ctx(tmp_path, stop_after=2)  # killed after generation 1 of the search
    with pytest.raises(KeyboardInterrupt):
        run(spec, ctx)
    resumed = run(spec, Ctx(tmp_path, checkpoint=ctx.checkpoints[-1]))
    assert numbers(resumed.summary) == numbers(res.summary)
    ctx = Ctx(tmp_path)  # resumed after the search, before its post-search steps
    run(spec, ctx)
    after = run(spec, Ctx(tmp_path, checkpoint=ctx.checkpoints[G]))
    assert numbers(after.summary) == numbers(res.summary)


def test_the_draw_differs_between_generations_and_seeds(tiny):
    assert draws_of(5, K, 0) == draws_of(5, K, 0)
    assert draws_of(5, K, 0) != draws_of(5, K, 1)
    assert draws_of(5, K, 1) != draws_of(6, K, 1)
    block = tiny[1].summary["robust"]["randomised"]
    assert block["models"] == K and block["aggregate"] == "cvar" and block["cvar_share"] == 0.5
    assert block["last_draw"]["generation"] == G and block["last_draw"]["draws"] == draws_of(5, K, G)
    assert len(block["last_draw"]["best_fitness_per_model"]) == K
    row = next(r for r in headline(tiny[1].summary) if r["label"] == "randomised search")
    assert row["value"].startswith(f"{K} random models per generation, CVaR of the worst 50 %")


def test_budget_counts_the_parents_rescoring(tiny):
    spec, res = tiny
    s = res.summary
    # generation 0: P x K walks; every later one: the trials and the parents, 2 x P x K
    assert [h["evaluations"] for h in s["history"]] == [P * K * (2 * g + 1) for g in range(G + 1)]
    assert spec.search_walks == P * K * (2 * G + 1)
    rs = s["random_search_history"]  # the control: twice the generations, P x K each: the same walks
    assert len(rs) == 2 * G + 1 and rs[-1]["evaluations"] == spec.search_walks
    assert s["timing"]["evaluations"] == spec.evaluations_budget == 2 * spec.search_walks + 3
    steps_per_walk = 1500  # 0.5 s settle + 1 s walk at 1 ms
    assert s["timing"]["sim_steps"] <= 2 * spec.search_walks * steps_per_walk
    assert s["timing"]["sim_steps"] > 0.5 * 2 * spec.search_walks * steps_per_walk


def test_cvar_is_the_mean_of_the_worst_share():
    f = np.array([[4.0, 1.0, 3.0, 2.0]])
    assert cvar(f, 0.5)[0] == 1.5 and cvar(f, 0.25)[0] == 1.0 and cvar(f, 1.0)[0] == 2.5 and cvar(f, 0.3)[0] == 1.5

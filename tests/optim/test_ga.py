"""The GA's ask/tell: bounds, elitism, progress on a known function, determinism and a
bit-identical resume from its JSON state."""

import json

import numpy as np
import pytest

from app.optim.ga import GeneticAlgorithm


def sphere(x):
    return ((x - 0.3) ** 2).sum(axis=1)


def run(ga, gens, stop_after=None):
    for g in range(gens):
        x = ga.ask()
        assert (x >= ga.lower).all() and (x <= ga.upper).all()
        ga.tell(sphere(x))
        if stop_after is not None and g + 1 == stop_after:
            return json.loads(json.dumps(ga.state()))
    return None


def test_ga_improves_and_keeps_its_elite():
    ga = GeneticAlgorithm(-np.ones(4), np.ones(4), population=20, seed=1)
    run(ga, 1)
    first = ga.best[1]
    bests = []
    for _ in range(30):
        ga.tell(sphere(ga.ask()))
        bests.append(ga.best[1])
    assert all(b2 <= b1 for b1, b2 in zip(bests, bests[1:]))  # elitism: never worse
    assert bests[-1] < first * 0.05


def test_ga_is_deterministic_and_resumes_bit_identically():
    a = GeneticAlgorithm(-np.ones(3), np.ones(3), population=10, seed=7)
    run(a, 12)
    b = GeneticAlgorithm(-np.ones(3), np.ones(3), population=10, seed=7)
    state = run(b, 12, stop_after=5)
    c = GeneticAlgorithm(-np.ones(3), np.ones(3), population=10, seed=7)
    c.restore(state)
    run(c, 7)
    assert c.generation == a.generation == 12
    assert np.array_equal(c.pop, a.pop) and np.array_equal(c.fit, a.fit)


def test_ga_rejects_bad_settings():
    with pytest.raises(ValueError):
        GeneticAlgorithm([0.0], [1.0], population=5)
    with pytest.raises(ValueError):
        GeneticAlgorithm([1.0], [0.0], population=4)
    ga = GeneticAlgorithm([0.0], [1.0], population=4)
    ga.ask()
    with pytest.raises(ValueError):
        ga.tell([1.0, 2.0])

"""scipy's DE as the peer of our DE (app/optim/scipy_de.py): set up as de.py is, it draws
the same initial population, searches the box it is given, honours the stop rule and is
reproducible from its seed."""

import numpy as np
import pytest

from app.optim import scipy_de
from app.optim.de import DifferentialEvolution

LO, HI = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.5, 3.0])
PEAK = np.array([0.3, 0.1, 2.7])


def _score(seen):
    def score(x):
        seen.append(x.copy())
        return -np.sum((x - PEAK) ** 2, axis=1)
    return score


def test_initial_population_is_our_des_and_every_candidate_in_the_box():
    seen = []
    out = scipy_de.run(_score(seen), LO, HI, population=12, generations=40, f=0.5, cr=0.6, seed=7)
    first = DifferentialEvolution(LO, HI, population=12, seed=7).ask()
    np.testing.assert_array_equal(seen[0], first)
    assert all(b.shape == (12, 3) for b in seen) and len(seen) == 41 == out["generations_run"]
    every = np.concatenate(seen)
    assert np.all(every >= LO) and np.all(every <= HI)
    assert np.linalg.norm(out["best_x"] - PEAK) < 0.05 and out["fitness"] > -2.5e-3


def test_same_seed_same_search_another_seed_another():
    runs = [scipy_de.run(_score([]), LO, HI, population=10, generations=5, f=0.5, cr=0.6, seed=s)["best_x"]
            for s in (3, 3, 4)]
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], runs[2])


def test_stop_rule_ends_the_search_after_the_generation_that_met_it():
    asked = []

    def stop(x):
        asked.append(x)
        return len(asked) == 3

    seen = []
    out = scipy_de.run(_score(seen), LO, HI, population=8, generations=50, f=0.5, cr=0.6, seed=0, stop=stop)
    assert len(asked) == 3 and out["generations_run"] == 4 and len(seen) == 4


def test_reversed_box_is_refused():
    with pytest.raises(ValueError, match="lower <= upper"):
        scipy_de.run(_score([]), HI, LO, population=8, generations=2, f=0.5, cr=0.6, seed=0)

"""DE (Eq. 7-10) and CMA-ES: convergence on analytic functions, bounds, checkpoints."""

import json

import numpy as np
import pytest

from app.optim.cmaes import CMAES
from app.optim.de import DifferentialEvolution
from app.optim.registry import make_optimizer


def sphere(x):
    return -np.sum((x - 0.3) ** 2, axis=1)  # maximum 0 at 0.3


def rosenbrock(x):
    return -np.sum(100 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1 - x[:, :-1]) ** 2, axis=1)


def optimise(opt, f, gens):
    for _ in range(gens):
        x = opt.ask()
        opt.tell(f(x))
    return opt.best


@pytest.mark.parametrize("name", ["de", "cmaes"])
def test_converges_on_sphere(name):
    opt = make_optimizer(name, -np.ones(8), np.ones(8), population=30, seed=3)
    x, f = optimise(opt, sphere, 150)
    assert f > -1e-6
    np.testing.assert_allclose(x, 0.3, atol=2e-3)


@pytest.mark.parametrize("name,gens,tol", [("de", 400, 1e-3), ("cmaes", 300, 1e-6)])
def test_converges_on_rosenbrock(name, gens, tol):
    opt = make_optimizer(name, -2 * np.ones(4), 2 * np.ones(4), population=30, seed=1)
    x, f = optimise(opt, rosenbrock, gens)
    assert f > -tol
    np.testing.assert_allclose(x, 1.0, atol=0.05)


def test_de_candidates_respect_bounds_and_the_trial_wins_ties():
    lo, hi = np.array([0.0, -1.0]), np.array([0.1, 5.0])
    de = DifferentialEvolution(lo, hi, population=10, f=1.0, cr=1.0, seed=0)
    for _ in range(20):
        x = de.ask()
        assert np.all(x >= lo) and np.all(x <= hi)
        de.tell(np.zeros(len(x)))  # all ties: Eq. 10 takes every trial
        np.testing.assert_array_equal(de.pop, x)


def test_de_mutation_is_current_to_best_1():
    """With CR = 1 every coordinate comes from Eq. 7's mutant (then Eq. 9's clip)."""
    de = DifferentialEvolution(-100 * np.ones(3), 100 * np.ones(3), population=6, cr=1.0, f=0.5, seed=4)
    x0 = de.ask()
    fit = -np.arange(6.0)
    de.tell(fit)
    state = de.rng.bit_generator.state
    u = de.ask()
    # Replay the draws: r1, r2 distinct and different from k.
    rng = np.random.default_rng()
    rng.bit_generator.state = state
    P = 6
    k = np.arange(P)
    r1 = (k + 1 + rng.integers(0, P - 1, size=P)) % P
    r2 = rng.integers(0, P - 2, size=P)
    lo, hi = np.minimum(k, r1), np.maximum(k, r1)
    r2 = np.where(r2 >= lo, r2 + 1, r2)
    r2 = np.where(r2 >= hi, r2 + 1, r2)
    assert np.all(r1 != k) and np.all(r2 != k) and np.all(r1 != r2)
    v = x0 + 0.5 * (x0[0] - x0) + 0.5 * (x0[r1] - x0[r2])
    np.testing.assert_allclose(u, np.clip(v, -100, 100))


@pytest.mark.parametrize("name", ["de", "cmaes"])
def test_checkpoint_restore_is_bit_identical(name):
    def run(split):
        opt = make_optimizer(name, -np.ones(5), np.ones(5), population=12, seed=9)
        xs = []
        for g in range(12):
            if g == split:
                state = json.loads(json.dumps(opt.state()))  # as stored in a database
                opt = make_optimizer(name, -np.ones(5), np.ones(5), population=12, seed=12345)
                opt.restore(state)
            x = opt.ask()
            xs.append(x)
            opt.tell(sphere(x))
        return np.array(xs), opt.best

    a, best_a = run(split=None)
    b, best_b = run(split=5)
    np.testing.assert_array_equal(a, b)
    assert best_a[1] == best_b[1]


def test_cmaes_state_is_plain_json_numbers():
    """Workers read checkpoints from the database: no pickle, only numbers and lists."""
    opt = make_optimizer("cmaes", -np.ones(3), np.ones(3), population=6, seed=1)
    for _ in range(3):
        opt.tell(sphere(opt.ask()))
    state = opt.state()

    def leaves(v):
        if isinstance(v, dict):
            return [x for u in v.values() for x in leaves(u)]
        if isinstance(v, list):
            return [x for u in v for x in leaves(u)]
        return [v]
    assert all(isinstance(v, (int, float)) or v is None for v in leaves(state))
    assert len(state["told"]) == 3 and state["generation"] == 3


def test_same_seed_same_numbers_other_seed_other_numbers():
    a = optimise(DifferentialEvolution(-np.ones(3), np.ones(3), seed=5), sphere, 5)
    b = optimise(DifferentialEvolution(-np.ones(3), np.ones(3), seed=5), sphere, 5)
    c = optimise(DifferentialEvolution(-np.ones(3), np.ones(3), seed=6), sphere, 5)
    np.testing.assert_array_equal(a[0], b[0])
    assert not np.array_equal(a[0], c[0])


def test_bad_configuration_is_rejected():
    with pytest.raises(ValueError, match="at least 4"):
        DifferentialEvolution(np.zeros(2), np.ones(2), population=3)
    with pytest.raises(ValueError, match="lower <= upper"):
        DifferentialEvolution(np.ones(2), np.zeros(2))
    with pytest.raises(ValueError, match="unknown optimizer"):
        make_optimizer("sgd", np.zeros(2), np.ones(2), 10, 0)
    with pytest.raises(ValueError, match="one fitness per candidate"):
        de = DifferentialEvolution(np.zeros(2), np.ones(2))
        de.ask()
        de.tell([1.0])
    assert CMAES(np.zeros(2), np.ones(2)).dim == 2

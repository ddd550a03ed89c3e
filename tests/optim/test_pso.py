"""PSO (paper 001, Eq. 1) on analytic functions; state round trip; bounds."""

import json

import numpy as np
import pytest

from app.optim.pso import ParticleSwarm
from app.optim.registry import make_optimizer


def _run(opt, f, gens):
    for _ in range(gens):
        x = opt.ask()
        opt.tell(f(x))
    return opt.best


def sphere(x):
    return -np.sum((x - 0.3) ** 2, axis=1)


def rosenbrock(x):
    return -np.sum(100 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1 - x[:, :-1]) ** 2, axis=1)


def test_paper_parameters_solve_the_sphere():
    opt = ParticleSwarm(-np.ones(6) * 5, np.ones(6) * 5, population=20, w=0.1, phi1=2.0, phi2=2.0, seed=1)
    x, f = _run(opt, sphere, 150)
    assert f > -1e-4
    assert np.allclose(x, 0.3, atol=1e-2)


def test_rosenbrock_with_inertia():
    opt = ParticleSwarm(-2 * np.ones(2), 2 * np.ones(2), population=30, w=0.7, phi1=1.5, phi2=1.5, seed=0)
    x, f = _run(opt, rosenbrock, 300)
    assert f > -1e-3 and np.allclose(x, 1.0, atol=0.05)


def test_positions_stay_in_bounds_and_best_is_monotone():
    lo, hi = np.array([0.0, -1.0, 2.0]), np.array([1.0, 1.0, 3.0])
    opt = ParticleSwarm(lo, hi, population=10, w=0.9, phi1=2.0, phi2=2.0, seed=4)
    last = -np.inf
    for _ in range(40):
        x = opt.ask()
        assert np.all(x >= lo) and np.all(x <= hi)
        opt.tell(-np.sum((x - np.array([5.0, 5.0, 5.0])) ** 2, axis=1))  # optimum outside the box
        assert opt.best[1] >= last
        last = opt.best[1]
    assert np.allclose(opt.best[0], hi, atol=1e-6)


def test_checkpoint_restores_bit_identical_continuation():
    def make():
        return make_optimizer("pso", -np.ones(4), np.ones(4), population=8, seed=11, w=0.1, phi1=2.0, phi2=2.0)

    a = make()
    _run(a, sphere, 5)
    state = json.loads(json.dumps(a.state()))
    b = make()
    b.restore(state)
    for _ in range(5):
        xa, xb = a.ask(), b.ask()
        assert np.array_equal(xa, xb)
        a.tell(sphere(xa))
        b.tell(sphere(xb))
    assert a.best[1] == b.best[1]


def test_same_seed_same_swarm_other_seed_differs():
    a = ParticleSwarm(-np.ones(3), np.ones(3), population=5, seed=2).ask()
    b = ParticleSwarm(-np.ones(3), np.ones(3), population=5, seed=2).ask()
    c = ParticleSwarm(-np.ones(3), np.ones(3), population=5, seed=3).ask()
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_bad_use_is_rejected():
    with pytest.raises(ValueError):
        ParticleSwarm(np.ones(2), np.zeros(2))
    opt = ParticleSwarm(np.zeros(2), np.ones(2), population=4)
    with pytest.raises(ValueError):
        opt.tell(np.zeros(4))  # nothing asked yet
    opt.ask()
    with pytest.raises(ValueError):
        opt.tell(np.zeros(3))

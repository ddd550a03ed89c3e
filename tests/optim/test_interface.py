"""The one optimiser interface (app/optim/base.py), checked on every registered optimiser:
the bounds are refused in one place, ask stays in the box, tell wants one value per row,
the state is JSON and a restore continues bit-identically."""

import json

import numpy as np
import pytest

from app.optim.base import Optimizer
from app.optim.ga import GeneticAlgorithm
from app.optim.registry import OPTIMIZERS, make_optimizer


def sphere(x):
    return -np.sum((x - 0.3) ** 2, axis=1)


def test_ga_is_registered():
    opt = make_optimizer("ga", np.zeros(2), np.ones(2), population=6, seed=0, crossover=0.8, cr=0.1)
    assert isinstance(opt, GeneticAlgorithm) and not opt.maximises and opt.crossover == 0.8


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_every_optimizer_has_the_interface(name):
    opt = make_optimizer(name, -np.ones(3), np.ones(3), population=6, seed=2)
    assert isinstance(opt, Optimizer) and opt.dim == 3 and opt.generation == 0
    x = opt.ask()
    assert x.shape == (6, 3) and np.all(x >= -1) and np.all(x <= 1)
    with pytest.raises(ValueError, match="one fitness per"):
        opt.tell(np.zeros(5))
    opt.tell(sphere(x))
    assert opt.generation == 1 and opt.best[0].shape == (3,)
    assert isinstance(opt.diagnostics(), dict)


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_every_optimizer_refuses_bad_bounds(name):
    with pytest.raises(ValueError, match="lower <= upper"):
        make_optimizer(name, np.ones(2), np.zeros(2), population=6, seed=0)
    with pytest.raises(ValueError, match="same shape"):
        make_optimizer(name, np.zeros(2), np.ones(3), population=6, seed=0)


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_every_optimizer_resumes_from_json(name):
    def run(split):
        opt = make_optimizer(name, -np.ones(4), np.ones(4), population=8, seed=5)
        xs = []
        for g in range(6):
            if g == split:
                state = json.loads(json.dumps(opt.state()))
                opt = make_optimizer(name, -np.ones(4), np.ones(4), population=8, seed=999)
                opt.restore(state)
            x = opt.ask()
            xs.append(x)
            opt.tell(sphere(x))
        return np.array(xs)

    np.testing.assert_array_equal(run(None), run(3))


def test_a_setting_no_optimizer_has_is_refused():
    with pytest.raises(TypeError, match="crosover"):
        make_optimizer("ga", np.zeros(2), np.ones(2), population=6, seed=0, crosover=0.8)


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_the_registry_knows_which_way_each_optimizer_looks(name):
    """MINIMISERS (which a kind's spec checks names against without loading every class)
    agrees with each class's own ``maximises``."""
    from app.optim.registry import MINIMISERS, check_name

    opt = make_optimizer(name, np.zeros(2), np.ones(2), population=6, seed=0)
    assert (name in MINIMISERS) == (not opt.maximises)
    assert check_name(name, maximise=opt.maximises) == name
    with pytest.raises(ValueError, match="allowed"):
        check_name(name, maximise=not opt.maximises)

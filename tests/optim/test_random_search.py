"""Random search: the equal-budget control of every population search."""

import json

import numpy as np
import pytest

from app.optim.random_search import RandomSearch
from app.optim.registry import make_optimizer


def test_uniform_in_the_box_best_is_monotone_and_the_true_best():
    lo, hi = np.array([0.0, -2.0]), np.array([1.0, 2.0])
    opt = make_optimizer("random", lo, hi, population=50, seed=3)
    seen_x, seen_f = [], []
    last = -np.inf
    for _ in range(10):
        x = opt.ask()
        assert np.all(x >= lo) and np.all(x <= hi)
        f = -np.sum((x - 0.5) ** 2, axis=1)
        opt.tell(f)
        seen_x.append(x)
        seen_f.append(f)
        assert opt.best[1] >= last
        last = opt.best[1]
    allx, allf = np.concatenate(seen_x), np.concatenate(seen_f)
    assert opt.best[1] == allf.max() and np.array_equal(opt.best[0], allx[np.argmax(allf)])
    # uniform: every coordinate's mean near the box centre
    assert np.allclose(allx.mean(axis=0), (lo + hi) / 2, atol=0.1 * (hi - lo))


def test_state_round_trip_continues_identically():
    a = RandomSearch(np.zeros(3), np.ones(3), population=4, seed=1)
    x = a.ask()
    a.tell(x.sum(axis=1))
    b = RandomSearch(np.zeros(3), np.ones(3), population=4, seed=99)
    b.restore(json.loads(json.dumps(a.state())))
    for _ in range(3):
        xa, xb = a.ask(), b.ask()
        assert np.array_equal(xa, xb)
        a.tell(xa.sum(axis=1))
        b.tell(xb.sum(axis=1))
    assert a.best[1] == b.best[1]


def test_bad_use_is_rejected():
    opt = RandomSearch(np.zeros(2), np.ones(2), population=3)
    with pytest.raises(ValueError):
        opt.tell(np.zeros(3))
    with pytest.raises(ValueError):
        opt.best
    opt.ask()
    with pytest.raises(ValueError):
        opt.tell(np.zeros(2))

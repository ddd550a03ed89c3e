"""The adaptation's model and methods (app/adapt): the fast Gaussian process against the
M-BOA formulas written out, ITE's proposal and stop rule as published, and what each part of
gaitmend's variant changes. The maps here are smooth functions over a 2-D behaviour space:
the evaluation on simulated robots is docs/adapt.md's; these check the arithmetic."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.adapt import methods as M
from app.adapt.model import GPSettings, posterior, posterior_reference


def _grid(n: int = 21) -> np.ndarray:
    g = np.linspace(0.0, 1.0, n)
    return np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)


def _map(name: str, f, trial_s: float = 5.0, lateral=None) -> M.Map:
    x = _grid()
    fwd = f(x) * trial_s
    return M.Map(name, x, fwd, np.zeros(len(x)) if lateral is None else lateral(x) * trial_s, trial_s)


def _peak(cx, cy, h=0.3, w=0.15):
    return lambda x: h * np.exp(-((x[:, 0] - cx) ** 2 + (x[:, 1] - cy) ** 2) / (2 * w * w))


def _trial(m: M.Map, i: int, speed: float, fell: bool = False, lateral_m: float = 0.0, duration_s: float = 5.0):
    return M.Trial(m.name, i, speed * duration_s, lateral_m, 0.0, fell, duration_s)


def test_the_gaussian_process_is_the_m_boa_formula():
    rng = np.random.default_rng(0)
    X = rng.random((300, 3))
    prior = rng.random(300)
    T = rng.random((7, 3))
    tp, y = rng.random(7), rng.random(7)
    p = posterior(X, prior, T, tp, y)
    mean, std, ll = posterior_reference(X, prior, T, tp, y)
    np.testing.assert_allclose(p.mean, mean, rtol=0, atol=1e-9)
    np.testing.assert_allclose(p.std, std, rtol=0, atol=1e-7)
    assert p.log_likelihood == pytest.approx(ll, rel=1e-9)
    # a different length scale gives a different posterior: the setting reaches the model
    assert not np.allclose(posterior(X, prior, T, tp, y, GPSettings(length_scale=0.1)).mean, p.mean)


def test_before_any_trial_ite_proposes_the_maps_best():
    m = _map("intact", _peak(0.7, 0.2))
    p = M.propose([m], [])
    assert p.elite == int(np.argmax(m.performance(False))) and p.map == "intact"
    assert p.std == pytest.approx(1.0) and p.acquisition == pytest.approx(p.predicted + 0.05)


def test_a_disappointing_trial_moves_the_next_proposal_away():
    m = _map("intact", _peak(0.7, 0.2))
    first = M.propose([m], [])
    trials = [_trial(m, first.elite, 0.0)]  # the best gait of the map does not walk at all
    post = posterior(m.descriptors, m.performance(False), m.descriptors[[first.elite]],
                     m.performance(False)[[first.elite]], np.array([0.0]))
    assert post.mean[first.elite] == pytest.approx(0.0, abs=1e-3)  # the measurement replaces the prior there
    nxt = M.propose([m], trials)
    assert nxt.elite != first.elite
    assert nxt.predicted < first.predicted


def test_ite_stops_at_ninety_percent_of_the_best_prediction_or_after_twenty():
    # two peaks far apart (beyond the kernel's reach): a poor trial at one leaves the other
    m = _map("intact", lambda x: _peak(0.1, 0.1)(x) + _peak(0.9, 0.9, h=0.28)(x))
    top = float(m.performance(False).max())
    i = int(np.argmax(m.performance(False)))
    d = M.decide([m], [_trial(m, i, 0.95 * top)])
    assert d.stop and d.best_trial == 0 and "0.9" in d.reason
    d = M.decide([m], [_trial(m, i, 0.5 * top)])
    assert not d.stop
    many = [_trial(m, k, 0.01) for k in range(20)]
    d = M.decide([m], many)
    assert d.stop and "20 trials" in d.reason
    assert not M.decide([m], many[:19]).stop


def test_several_priors_choose_the_map_that_explains_the_trials():
    intact = _map("intact", _peak(0.2, 0.2))
    damaged = _map("leg 1 lost", _peak(0.8, 0.7, h=0.2))
    truth = damaged.performance(False)
    rng = np.random.default_rng(1)
    trials = [_trial(intact, int(k), float(truth[k])) for k in rng.choice(len(truth), 4, replace=False)]
    p = M.propose([intact, damaged], trials, M.GAITMEND)
    assert p.map == "leg 1 lost"
    assert p.log_likelihood["leg 1 lost"] > p.log_likelihood["intact"]
    # ITE holds the first map only, whatever the trials say
    assert M.propose([intact, damaged], trials, M.ITE).map == "intact"


def test_straight_and_falls_change_the_performance_as_stated():
    t = M.Trial("m", 0, forward_m=1.0, lateral_m=-0.4, yaw_rad=0.1, fell=True, duration_s=5.0)
    assert t.performance(straight=False, falls=False) == pytest.approx(0.2)
    assert t.performance(straight=True, falls=False) == pytest.approx(0.12)
    assert t.performance(straight=True, falls=True) == 0.0
    m = _map("m", _peak(0.5, 0.5), lateral=lambda x: 0.5 * x[:, 0])
    assert not np.allclose(m.performance(True), m.performance(False))
    # a drifting map's best straight gait is not its fastest
    assert int(np.argmax(m.performance(True))) != int(np.argmax(m.performance(False)))


def test_the_same_trials_give_the_same_proposal():
    m = _map("intact", _peak(0.3, 0.6))
    trials = [_trial(m, 10, 0.1), _trial(m, 200, 0.05, fell=True)]
    assert M.propose([m], trials, M.GAITMEND) == M.propose([m], trials, M.GAITMEND)


def test_maps_must_share_their_descriptor_space():
    a = _map("a", _peak(0.5, 0.5))
    b = M.Map("b", np.zeros((3, 4)), np.zeros(3), np.zeros(3), 5.0)
    with pytest.raises(ValueError, match="dimension"):
        M.propose([a, b], [], M.GAITMEND)
    with pytest.raises(ValueError, match="own name"):
        M.propose([a, a], [], M.GAITMEND)


def test_the_guarded_stop_rule_never_stops_on_a_gait_that_does_not_walk():
    # a map that predicts nothing walks (every prediction <= 0): as published, ITE's rule stops on the
    # first trial that measures 0 (0 >= 0.9 x a best prediction <= 0): a robot standing still
    m = _map("flat", lambda x: -0.02 - 0.01 * x[:, 0])
    i = int(np.argmax(m.performance(False)))
    still = [_trial(m, i, 0.0)]
    ite = M.decide([m], still, M.ITE)
    assert ite.max_predicted <= 0 and ite.stop and "0.9" in ite.reason  # the published rule, kept exact for ITE
    guarded = M.decide([m], still, M.GAITMEND)
    assert not guarded.stop and "does not walk" in guarded.reason
    # the guard is the only difference: ITE with it on goes on too, and a trial that walks stops both
    assert not M.decide([m], still, dataclasses.replace(M.ITE, walks_to_stop=True)).stop
    walks = still + [_trial(m, 0, 0.05)]
    assert M.decide([m], walks, M.ITE).stop and M.decide([m], walks, M.GAITMEND).stop
    # a fall counts 0 for gaitmend: never a stop on its own either
    assert not M.decide([m], [_trial(m, i, 0.3, fell=True)], M.GAITMEND).stop
    # no rule stops before a trial was measured; both stop after 20
    assert not M.decide([m], [], M.ITE).stop and not M.decide([m], [], M.GAITMEND).stop
    assert M.decide([m], [_trial(m, k, -0.05) for k in range(20)], M.GAITMEND).stop

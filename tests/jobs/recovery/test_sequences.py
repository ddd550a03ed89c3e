"""Gait-sequence planner: invariants over every 1- and 2-leg loss of the hexapod."""

import itertools

import numpy as np
import pytest

from app.jobs.recovery.sequences import (
    InfeasibleMorphology,
    hexapod_neighbours,
    nominal_tripod,
    plan_general,
    plan_hexapod,
)
from app.jobs.recovery.trajectory import swing_mask
from app.robots.catalog import JETHEXA
from app.robots.damage import DamageSpec

FEET = JETHEXA.nominal_feet_xy()
LOSSES = [c for k in (0, 1, 2) for c in itertools.combinations(range(1, 7), k)]


def feasible(lost):
    legs = [l for l in range(1, 7) if l not in lost]
    return sum(l % 2 for l in legs) >= 2 and sum(1 - l % 2 for l in legs) >= 2


@pytest.mark.parametrize("lost", [l for l in LOSSES if feasible(l)], ids=str)
def test_every_leg_swings_once_no_neighbours_three_support(lost):
    seq = plan_hexapod(lost, FEET)
    legs = [l for l in range(1, 7) if l not in lost]
    assert seq.legs == legs
    assert seq.sigma == {6: 2, 5: 3, 4: 4}[len(legs)]
    assert seq.name == {6: "tripod", 5: "modified_quadrangular", 4: "modified_pentagonal"}[len(legs)]
    groups = seq.groups()
    assert sorted(l for g in groups for l in g) == legs  # each leg in exactly one phase
    assert all(groups), "a phase without a swinging leg wastes a third of the period"
    for g in groups:
        assert len(legs) - len(g) >= 3
        for a, b in itertools.combinations(g, 2):
            assert b not in hexapod_neighbours(a), f"neighbours {a},{b} swing together in {groups}"

    # The same invariants on the trajectories: over a fine time grid each leg is in swing
    # for exactly 1/sigma of the period, and at least three legs always support.
    t = np.linspace(0, 1.2, 12 * 97, endpoint=False)
    sw = swing_mask(t, 0.6, seq, legs)
    np.testing.assert_allclose(sw.mean(axis=0), 1 / seq.sigma, atol=2e-3)
    assert (len(legs) - sw.sum(axis=1)).min() >= 3


@pytest.mark.parametrize("lost", [l for l in LOSSES if len(l) == 1], ids=str)
def test_quadrangular_choice_has_the_best_worst_case_support_margin(lost):
    """Brute force over every valid 3-phase assignment: none keeps the damaged robot's
    centre of mass further inside its support polygons than the planner's choice."""
    from app.jobs.recovery.sequences import support_margin

    _, model = JETHEXA.model(DamageSpec(lost_legs=lost))
    com = np.array(JETHEXA.stance_com_xy(model, 0.10))
    # losing a leg moves the centre of mass away from it
    assert np.dot(com, FEET[lost[0]]) < 0
    seq = plan_hexapod(lost, FEET, com)
    legs = seq.legs

    def worst(groups):
        return min(support_margin(np.array([FEET[l] for l in legs if l not in g]), com) for g in groups)

    best = -np.inf
    for assign in itertools.product(range(3), repeat=len(legs)):
        groups = [[l for l, a in zip(legs, assign) if a == k] for k in range(3)]
        if any(not g or len(g) > 2 for g in groups):
            continue
        if any(b in hexapod_neighbours(a) for g in groups for a, b in itertools.combinations(g, 2)):
            continue
        best = max(best, worst(groups))
    assert worst(seq.groups()) == pytest.approx(best)


@pytest.mark.parametrize("lost", [l for l in LOSSES if len(l) <= 2 and not feasible(l)] + [(1, 2, 3), (1, 3, 5, 2)], ids=str)
def test_infeasible_morphologies_fail_clearly(lost):
    with pytest.raises(InfeasibleMorphology, match="at least 4 legs with at least 2 on each side"):
        plan_hexapod(lost, FEET)


def test_nominal_tripod_groups_are_the_papers():
    seq = nominal_tripod(list(range(1, 7)))
    assert seq.groups() == [[1, 4, 5], [2, 3, 6]]


def test_typeset_algorithm_2_is_the_defect_we_fix():
    """As typeset, lambda ends as the second leg of the intact group: with leg 1 lost,
    leg 3 would swing twice and leg 6 never. The planner gives every leg one phase."""
    L1, L2 = (1, 4, 5), (2, 3, 6)
    x = {l: (0 if l == 1 else 1) for l in range(1, 7)}
    alpha = [i for i in L1 if x[i]]
    beta, lam = [], None
    gamma = 1
    for i in L2:
        if x[i]:
            beta.append(i)
            gamma += 1
        if gamma == 3:
            lam = i
    typeset = [alpha[0], beta[1], alpha[1], beta[0], lam]
    assert sorted(typeset) != [2, 3, 4, 5, 6]  # one leg twice, one never
    seq = plan_hexapod((1,), FEET)
    assert sorted(l for g in seq.groups() for l in g) == [2, 3, 4, 5, 6]


def test_general_planner_other_leg_counts():
    """Remark 1: an octopod (4 per side) gets a two-phase gait with 4 legs in support."""
    feet = {l: ((-1 if l % 2 else 1) * 0.2, 0.3 - 0.2 * ((l - 1) // 2)) for l in range(1, 9)}

    def nbrs(l):
        return {n for n in (l - 2, l + 2, l + 1 if l % 2 else l - 1) if 1 <= n <= 8}

    seq = plan_general(range(1, 9), feet, nbrs)
    assert seq.sigma == 2
    for g in seq.groups():
        assert len(g) == 4
        assert not any(b in nbrs(a) for a, b in itertools.combinations(g, 2))

"""Adjustment leg (Table II rule), reachable space (Eq. 10-13), foothold (Eq. 14), IK, quintic."""

import math

import numpy as np
import pytest

from app.robots.heavy_hexapod import HEAVY, LEG_IDS, TRIPODS
from app.jobs.tipping.stability.foothold import (SwingPlan, leg_fk, leg_ik, optimal_foothold, quintic_coeffs, quintic_eval,
                                    reachable, reachable_space, select_adjustment_leg, side_of_axis)
from app.jobs.tipping.stability.polygon import ccw_order, fit_plane

# Table II with its marks restored: the paper's six runs (Sec. 5.2) fix a35->6, a51->4,
# a13->2 and a62->3, a24->1, a46->5.
TABLE_II = {(1, 3): 2, (3, 5): 6, (5, 1): 4, (2, 4): 1, (4, 6): 5, (6, 2): 3}


def _edges(tripod):
    feet = {l: HEAVY.nominal_foot(l) for l in LEG_IDS}
    pts = np.stack([feet[l] for l in tripod])
    order = [tripod[i] for i in ccw_order(pts)]
    return feet, [(order[i], order[(i + 1) % 3]) for i in range(3)]


@pytest.mark.parametrize("tripod", TRIPODS)
def test_leg_selection_rule_on_every_edge(tripod):
    feet, edges = _edges(tripod)
    normal, origin = fit_plane(np.stack([feet[l] for l in tripod]))
    spaces = {l: reachable_space(HEAVY.workspace(l), normal, origin, 0.9) for l in LEG_IDS if l not in tripod}
    for i, j in edges:
        leg, lever = select_adjustment_leg((feet[i], feet[j]), spaces)
        key = (i, j) if (i, j) in TABLE_II else (j, i)
        assert leg == TABLE_II[key], f"edge a{i}{j}"
        assert lever > 0.3
        # The chosen foothold lies outside the edge and inside the leg's workspace.
        label, p, arm = optimal_foothold(spaces[leg], feet[i], feet[j])
        assert arm == pytest.approx(float(side_of_axis(p[None], feet[i], feet[j])[0]))
        assert arm > 0.3
        x, d, th = leg_ik(HEAVY.workspace(leg), p)
        assert reachable(HEAVY.workspace(leg), x - 0.0, d, th, tol=1e-6)


def test_leg_selection_on_a_tilted_ground_plane():
    # The rule is geometric: a 15 deg roll of the fitted ground keeps the same answers.
    tripod = (1, 3, 5)
    feet, edges = _edges(tripod)
    c, s = math.cos(0.26), math.sin(0.26)
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    tf = {l: R @ p for l, p in feet.items()}
    normal, origin = fit_plane(np.stack([tf[l] for l in tripod]))
    spaces = {l: reachable_space(HEAVY.workspace(l), normal, origin, 0.9) for l in (2, 4, 6)}
    for i, j in edges:
        assert select_adjustment_leg((tf[i], tf[j]), spaces)[0] == TABLE_II[(i, j)]


def test_side_test_eq14():
    p_i, p_j = np.zeros(3), np.array([1.0, 0, 0])
    assert side_of_axis(np.array([[0.5, -1.0, 0]]), p_i, p_j)[0] == pytest.approx(1.0)  # right = outside (CCW)
    assert side_of_axis(np.array([[0.5, 2.0, 0]]), p_i, p_j)[0] == pytest.approx(-2.0)


def test_reachable_space_bounds_and_rho():
    ws = HEAVY.workspace(2)
    n, o = np.array([0.0, 0, 1]), np.array([0.0, 0, -1.74])
    full = reachable_space(ws, n, o, rho=1.0)
    safe = reachable_space(ws, n, o, rho=0.9)
    for sp in (full, safe):
        for p in sp.points().values():
            assert p[2] == pytest.approx(-1.74, abs=1e-9)
            x, d, th = leg_ik(ws, p)
            assert reachable(ws, x, d, th, tol=1e-2)
    assert full.R[1] > safe.R[1] > ws.hip[1]  # left leg: R is the outer end, rho pulls it in
    assert full.L[1] < safe.L[1] < safe.R[1]
    # Here H (straight under the hip) needs theta < -10 deg, so rho shrinks [L, R] about its middle.
    assert safe.R[1] - safe.L[1] == pytest.approx(0.9 * (full.R[1] - full.L[1]))
    assert reachable_space(ws, n, np.array([0.0, 0, -5.0])) is None  # ground out of reach


def test_ik_round_trip():
    rng = np.random.default_rng(0)
    for leg in LEG_IDS:
        ws = HEAVY.workspace(leg)
        q = np.stack([rng.uniform(*ws.x_range, 50), rng.uniform(*ws.d_range, 50), rng.uniform(*ws.theta_range, 50)], 1)
        p = leg_fk(ws, q[:, 0], q[:, 1], q[:, 2])
        np.testing.assert_allclose(leg_ik(ws, p), q, atol=1e-9)


def test_quintic_boundary_conditions_and_swing():
    p0, v0, a0 = np.array([0.0, 1, 2]), np.array([0.5, 0, -0.2]), np.array([0.0, 1, 0])
    p1 = np.array([1.0, -1, 0.5])
    c = quintic_coeffs(p0, v0, a0, p1, np.zeros(3), np.zeros(3), 1.7)
    np.testing.assert_allclose(quintic_eval(c, 0.0)[0], p0)
    np.testing.assert_allclose(quintic_eval(c, 0.0, 1)[0], v0)
    np.testing.assert_allclose(quintic_eval(c, 0.0, 2)[0], a0)
    np.testing.assert_allclose(quintic_eval(c, 1.7)[0], p1, atol=1e-12)
    np.testing.assert_allclose(quintic_eval(c, 1.7, 1)[0], 0, atol=1e-12)
    np.testing.assert_allclose(quintic_eval(c, 1.7, 2)[0], 0, atol=1e-9)
    plan = SwingPlan.plan(p0, v0, a0, p1, 1.7, 0.3, np.array([0, 0, 1.0]))
    np.testing.assert_allclose(plan.at(1.7)[0], p1, atol=1e-12)
    mid = plan.at(0.85)[0]
    assert mid[2] == pytest.approx(quintic_eval(c, 0.85)[0][2] + 0.3)

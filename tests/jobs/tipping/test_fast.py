"""The scalar per-step fast paths agree with the batched reference implementations."""

import numpy as np
import pytest

from app.jobs.tipping.stability.fast import distribute_fast, hull_ccw, margins, plane_normal
from app.jobs.tipping.stability.fasm import fasm_edges, net_wrench_from_contacts
from app.jobs.tipping.stability.polygon import ccw_order, fit_plane, nesm, ssm
from app.jobs.tipping.stability.qp import distribute

BASE = np.array([[2.4, 1.9, 0.0], [-2.4, 1.9, 0.0], [0.0, -1.9, 0.0], [-2.4, -1.9, 0.0], [2.4, -1.9, 0.0], [0.0, 1.9, 0.0]])


@pytest.mark.parametrize("k", [3, 4, 5, 6])
def test_margins_match_reference(k):
    rng = np.random.default_rng(k)
    for _ in range(50):
        feet = BASE[:k] + rng.normal(0, 0.1, (k, 3))
        com = np.array([0.2, 0.1, 1.8]) + rng.normal(0, 0.4, 3)
        forces = rng.normal(0, 300, (k, 3)) + [0, 0, 5e4 / k]
        order = ccw_order(feet)
        assert hull_ccw(feet.tolist()) == list(order)
        f_r, n_r = net_wrench_from_contacts(feet, forces, com)
        ref = np.degrees(fasm_edges(feet[order], com, f_r, n_r))
        th, s, e = margins(feet.tolist(), forces.tolist(), com.tolist(), list(order))
        np.testing.assert_allclose(th, ref, atol=1e-9)
        assert s == pytest.approx(ssm(feet[order], com)[0], abs=1e-9)
        assert e == pytest.approx(nesm(feet[order], com)[0], abs=1e-9)


def test_qp_matches_reference():
    rng = np.random.default_rng(7)
    disagree = 0
    for _ in range(60):
        feet = BASE[:4] + rng.normal(0, 0.1, (4, 3))
        com = np.array([0.3, 0.1, 1.8]) + rng.normal(0, 0.2, 3)
        n = np.array(plane_normal(feet.tolist()))
        np.testing.assert_allclose(n, fit_plane(feet)[0], atol=1e-12)
        bx = np.array([1.0, 0.1, 0.0])
        a = distribute(feet, com, 5000.0, normal=n, body_x=bx)
        b = distribute_fast(feet.tolist(), com.tolist(), 5000.0, normal=tuple(n), body_x=tuple(bx))
        np.testing.assert_allclose(a.cone_alpha_deg, b.cone_alpha_deg, atol=1e-9)
        if a.stability_constrained != b.stability_constrained:
            disagree += 1  # a pyramid that is feasible only to rounding: either answer is right
            continue
        np.testing.assert_allclose(a.forces, b.forces, atol=1e-3 * 5000 * 9.81)
        np.testing.assert_allclose(a.constraint_matrix, b.constraint_matrix, atol=1e-9)
    assert disagree <= 2


def test_qp_with_a_desired_acceleration_matches_reference():
    rng = np.random.default_rng(8)
    for _ in range(20):
        feet = BASE[:4] + rng.normal(0, 0.1, (4, 3))
        com = np.array([0.3, 0.1, 1.8]) + rng.normal(0, 0.2, 3)
        acc, moment = rng.normal(0, 0.5, 3), rng.normal(0, 2000.0, 3)
        a = distribute(feet, com, 5000.0, acc=acc, moment=moment, stability=False)
        b = distribute_fast(feet.tolist(), com.tolist(), 5000.0, acc=tuple(acc), moment=tuple(moment), stability=False)
        np.testing.assert_allclose(a.forces, b.forces, atol=1e-6 * 5000 * 9.81)

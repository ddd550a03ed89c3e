"""QP foot-force distribution (Eq. 16-18) with friction and FASM pyramids (Eq. 19-24)."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from app.jobs.tipping.stability.fasm import fasm_edges, net_wrench_from_contacts
from app.jobs.tipping.stability.polygon import ccw_order, tangent_basis
from app.jobs.tipping.stability.qp import distribute, skew, stability_rows

M = 5000.0
G = np.array([0.0, 0.0, -9.81])
FEET4 = np.array([[2.4, 1.9, 0.0], [-2.4, 1.9, 0.0], [0.0, -1.9, 0.0], [-2.4, -2.0, 0.0]])


def _check_friction(forces, normal, mu):
    t1, t2 = tangent_basis(normal)
    for f in forces:
        fn = f @ normal
        assert fn >= -1e-6
        assert abs(f @ t1) <= mu / math.sqrt(2) * fn + 1e-6
        assert abs(f @ t2) <= mu / math.sqrt(2) * fn + 1e-6


def test_feasible_supports_the_weight_and_meets_every_constraint():
    com = np.array([-0.3, 0.1, 1.8])
    sol = distribute(FEET4, com, M, G, mu=0.8)
    assert sol.stability_constrained
    np.testing.assert_allclose(sol.forces.sum(axis=0), [0, 0, M * 9.81], rtol=0, atol=0.02 * M * 9.81)
    _check_friction(sol.forces, np.array([0, 0, 1.0]), 0.8)
    x = sol.forces.ravel()
    assert np.all(sol.constraint_matrix @ x - sol.constraint_lower >= -1e-6 * M * 9.81)
    # The FASM of the distributed forces is positive about every edge (f* inside the cone).
    order = ccw_order(FEET4)
    f_r, n_r = net_wrench_from_contacts(FEET4, sol.forces, com)
    assert np.all(fasm_edges(FEET4[order], com, f_r, n_r) > 0)


def test_solution_matches_a_slow_reference_solver():
    com = np.array([0.2, -0.2, 1.7])
    feet = FEET4 + [0, 0, 0.05]
    sol = distribute(feet, com, M, G, mu=0.7)
    C, lo = sol.constraint_matrix, sol.constraint_lower / (M * 9.81)
    k = len(feet)
    A = np.vstack([np.tile(np.eye(3), (1, k)), np.concatenate(list(skew(feet - com)), axis=1)])
    b = np.concatenate([-M * G, np.zeros(3)]) / (M * 9.81)
    S = np.diag([1, 1, 1, 10, 10, 10.0])

    def obj(x):
        r = A @ x - b
        return r @ S @ r + 1e-3 * x @ x

    x0 = np.tile([0, 0, 1.0 / k], k)
    ref = minimize(obj, x0, constraints=[{"type": "ineq", "fun": lambda x: C @ x - lo, "jac": lambda x: C}],
                   method="SLSQP", options={"ftol": 1e-12, "maxiter": 500})
    assert ref.success
    x = sol.forces.ravel() / (M * 9.81)
    assert obj(x) <= obj(ref.x) + 1e-7
    np.testing.assert_allclose(x, ref.x, atol=2e-3)


def test_stability_pyramid_binds_when_the_weight_leaves_the_cone():
    # CoM far toward one edge: plain support would put the net force outside the cone, so
    # the pyramid changes the solution (or is reported infeasible and dropped).
    com = np.array([1.4, 1.3, 1.8])
    free = distribute(FEET4, com, M, G, stability=False)
    cons = distribute(FEET4, com, M, G)
    rows, alpha = stability_rows(FEET4, com, np.array([1.0, 0, 0]), np.array([0, 0, 1.0]))
    assert np.min(rows @ (free.forces.ravel() / (M * 9.81))) < 0
    assert np.all(alpha > 0) and np.all(alpha < 90)
    if cons.stability_constrained:
        assert np.min(rows @ (cons.forces.ravel() / (M * 9.81))) >= -1e-9
    _check_friction(cons.forces, np.array([0, 0, 1.0]), 0.8)


def test_tilted_ground_friction_cone():
    n = np.array([0.0, math.sin(0.3), math.cos(0.3)])
    feet = FEET4.copy()
    feet[:, 2] = -feet[:, 1] * math.tan(0.3)
    sol = distribute(feet, np.array([0, 0, 1.8]), M, G, normal=n, mu=0.6, stability=False)
    _check_friction(sol.forces, n, 0.6)

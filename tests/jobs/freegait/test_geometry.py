"""SM, SM_t, L, K(P) against hand-computed configurations; transfer timing (Eq. 7-10)."""

import math

import numpy as np
import pytest

from app.jobs.freegait.planner.geometry import (Motion, kinematic_margin, polygon_margin, transfer_points,
                                            transfer_points_path, triangle_margin, zeta)
from app.jobs.freegait.planner.params import GaitParams, r1, r2, r3, transfer_times

# A symmetric tripod: front (0.4, 0.5), centre (0, -0.5), rear (-0.4, 0.5).
F, C, R = np.array([0.4, 0.5]), np.array([0.0, -0.5]), np.array([-0.4, 0.5])
S116 = math.sqrt(1.16)  # length of the edge direction (-0.4, 1)


def test_stability_margin_by_hand():
    # Distance from the origin to the line through C and R: |(0,0.5) x (-0.4,1)| / |(-0.4,1)| = 0.2 / sqrt(1.16).
    assert triangle_margin(F, C, R) == pytest.approx(0.2 / S116)
    # Near the left side y = 0.5, that edge is the closest.
    assert triangle_margin(F, C, R, np.array([0.0, 0.45])) == pytest.approx(0.05)
    # Outside: negative.
    assert triangle_margin(F, C, R, np.array([0.0, 0.6])) == pytest.approx(-0.1)
    # The hull of all six nominal feet of a rectangle 0.8 x 1.0: 0.4 from the front.
    six = np.array([[0.4, 0.5], [0.4, -0.5], [0, 0.5], [0, -0.5], [-0.4, 0.5], [-0.4, -0.5]])
    assert polygon_margin(six) == pytest.approx(0.4)


def test_transfer_points_and_l_by_hand():
    d = np.array([1.0, 0.0])
    # Mirror symmetry x -> -x swaps the rear and front edges: I = (-R_e/2, 0), F = (R_e/2, 0).
    t, l, smt = transfer_points(F, C, R, Motion(0.02, 0.0), 0.2)
    assert t == pytest.approx(-0.1) and l == pytest.approx(-0.1)
    # dist((-0.1, 0), CR) = |(-0.1, 0.5) x (-0.4, 1)| / sqrt(1.16) = 0.1 / sqrt(1.16)
    assert smt == pytest.approx(0.1 / S116)
    # The same tripod 0.3 m ahead: the COG must travel 0.2 m to reach I (Def. 4).
    _, l2, smt2 = transfer_points(F + [0.3, 0], C + [0.3, 0], R + [0.3, 0], Motion(0.02, 0.0), 0.2)
    assert l2 == pytest.approx(0.2) and smt2 == pytest.approx(smt)
    del d


def test_condition_1_3_holds_at_crab_angle():
    m = Motion(0.02, math.radians(20))
    t, _, smt = transfer_points(F, C, R, m, 0.15)
    i, e = t * m.direction, (t + 0.15) * m.direction
    from tests.jobs.freegait.reference import _dist_line

    assert _dist_line(i, C, R, F) == pytest.approx(_dist_line(e, F, C, R), abs=1e-12)
    assert np.linalg.norm(e - i) == pytest.approx(0.15)  # condition 1.2
    assert smt == pytest.approx(min(_dist_line(i, C, R, F), _dist_line(i, R, F, C), _dist_line(e, R, F, C)))


def test_circling_with_a_huge_radius_is_the_crab_gait():
    m_line = Motion(0.02, math.radians(10))
    m_arc = Motion(0.02, math.radians(10), omega=1e-6)
    a = transfer_points(F, C, R, m_line, 0.12)
    b = transfer_points_path(F, C, R, m_arc, 0.12)
    assert b[0] == pytest.approx(a[0], abs=1e-6) and b[2] == pytest.approx(a[2], abs=1e-6)


def test_kinematic_margin_by_hand():
    rect = np.array([0.24, 0.49, 0.49, 0.65])
    p = np.array([0.4, 0.57])
    m = Motion(0.02, 0.0)
    prm = GaitParams()
    assert r1(m, prm) == pytest.approx(0.02 * 0.13 / 0.10)
    # zeta: 0.4 - 0.24 back to the rear edge; K = zeta - R_1 (Eq. 13)
    assert kinematic_margin(p, rect, m, r1(m, prm)) == pytest.approx(0.16 - 0.026)
    m20 = Motion(0.02, math.radians(20))
    # Along -(cos 20, sin 20): the rear edge after 0.16 / cos 20 = 0.17027, the inner edge after 0.08 / sin 20 = 0.2339.
    assert zeta(p, rect, m20) == pytest.approx(0.16 / math.cos(math.radians(20)))
    # Outside the workspace the margin is negative.
    assert zeta(np.array([0.2, 0.57]), rect, m) < 0


def test_angular_kinematic_margin_spinning_by_hand():
    # Spinning left: a ground point at (0, 0.57) moves to (0.57 sin th, 0.57 cos th) in the body frame and
    # leaves x <= 0.125 at th = asin(0.125 / 0.57) (Eq. 25's psi).
    rect = np.array([-0.125, 0.125, 0.49, 0.65])
    psi = zeta(np.array([0.0, 0.57]), rect, Motion(0.0, 0.0, omega=0.1))
    assert psi == pytest.approx(math.asin(0.125 / 0.57), abs=1.5e-3)


def test_transfer_timing_eq_7_to_10():
    prm = GaitParams()
    m = Motion(0.02, 0.0)
    assert r1(m, prm) == pytest.approx(0.02 * 0.13 / 0.10)  # Eq. 7
    assert r2(m, prm, 0.10, 0.40) == pytest.approx(0.02 * 0.30 / 0.30)  # Eq. 9 (magnitude)
    assert r3(m, prm) == pytest.approx(0.02 * 0.20 / 0.10)  # Eq. 10
    t1, t2, t3 = transfer_times(prm, np.array([0.1, 0.0, -0.2]), np.array([0.4, 0.15, 0.0]))
    assert (t1, t2, t3) == pytest.approx((1.3, 1.0, 2.0))  # subphase 2: the slowest leg (Eq. 11)

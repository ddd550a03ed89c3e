"""FASM (Eq. 3-9), SSM, NESM and time-to-tip against hand-computed cases."""

import math

import numpy as np
import pytest

from app.jobs.tipping.stability.fasm import TipDetector, fasm, fasm_edges, net_wrench_from_contacts, time_to_tip
from app.jobs.tipping.stability.polygon import ccw_order, fit_plane, nesm, polygon_centroid, ssm

A, H, M, G = 1.0, 1.5, 100.0, 9.81
SQUARE = np.array([[A, -A, 0.0], [A, A, 0.0], [-A, A, 0.0], [-A, -A, 0.0]])  # CCW from above
COM = np.array([0.0, 0.0, H])
WEIGHT = np.array([0.0, 0.0, -M * G])


def test_box_on_symmetric_polygon_has_equal_angles_atan_a_over_h():
    th = np.degrees(fasm_edges(SQUARE, COM, WEIGHT, np.zeros(3)))
    np.testing.assert_allclose(th, math.degrees(math.atan(A / H)), atol=1e-9)


def test_force_pushing_across_one_edge():
    # Edge 0 joins (A,-A) -> (A,A): the +x side. A push F along +x tilts f_r toward it.
    for F in (0.3 * M * G, 0.9 * M * G):
        th = np.degrees(fasm_edges(SQUARE, COM, WEIGHT + [F, 0, 0], np.zeros(3)))
        base, push = math.atan(A / H), math.atan(F / (M * G))
        assert th[0] == pytest.approx(math.degrees(base - push), abs=1e-9)
        assert th[2] == pytest.approx(math.degrees(base + push), abs=1e-9)
        # Side edges run along x: the push is along them and drops out (Eq. 5).
        assert th[1] == pytest.approx(math.degrees(base), abs=1e-9)
        assert th[3] == pytest.approx(math.degrees(base), abs=1e-9)
    margin, edge = fasm(SQUARE, COM, WEIGHT + [0.9 * M * G, 0, 0], np.zeros(3))
    assert edge == 0 and margin < 0  # F/mg = 0.9 > a/h = 0.667: tips over the +x edge


def test_couple_about_an_edge_acts_like_the_equivalent_force():
    # A pitch couple N about +y on edge 0 (axis +y) adds l^ x n / |l| = (h N, 0, a N) / |l|^2.
    N = 200.0
    th = fasm_edges(SQUARE, COM, WEIGHT, np.array([0.0, N, 0.0]))[0]
    l = np.array([A, 0.0, -H])
    f_star = WEIGHT + np.array([H * N, 0.0, A * N]) / (l @ l)
    expect = math.acos(f_star @ l / np.linalg.norm(f_star) / np.linalg.norm(l))
    assert th == pytest.approx(expect, abs=1e-12)
    assert th < math.atan(A / H)


def test_margin_is_zero_when_only_the_edge_feet_carry_the_load():
    # Support forces only at the two feet of edge 0, balancing any net load: FASM = 0 there.
    forces = np.zeros((4, 3))
    forces[0] = [10.0, 20.0, 500.0]
    forces[1] = [-30.0, 5.0, 700.0]
    f_r, n_r = net_wrench_from_contacts(SQUARE, forces, COM + [0.2, 0.1, 0.0])
    th = fasm_edges(SQUARE, COM + [0.2, 0.1, 0.0], f_r, n_r)
    assert th[0] == pytest.approx(0.0, abs=1e-7)


def test_batched_equals_single():
    rng = np.random.default_rng(3)
    feet = SQUARE + rng.normal(0, 0.05, (16, 4, 3))
    com = COM + rng.normal(0, 0.1, (16, 3))
    f = WEIGHT + rng.normal(0, 100, (16, 3))
    n = rng.normal(0, 50, (16, 3))
    batch = fasm_edges(feet, com, f, n)
    for b in range(16):
        np.testing.assert_allclose(batch[b], fasm_edges(feet[b], com[b], f[b], n[b]), atol=1e-12)


def test_ssm_nesm_on_the_box():
    s, per = ssm(SQUARE, COM)
    assert s == pytest.approx(A)
    e, _ = nesm(SQUARE, COM)
    assert e == pytest.approx(math.hypot(A, H) - H)
    s_out, _ = ssm(SQUARE, COM + [1.5, 0, 0])
    assert s_out == pytest.approx(-0.5)


def test_ccw_order_and_plane_and_centroid():
    pts = SQUARE[[2, 0, 3, 1]]
    order = ccw_order(pts)
    poly = pts[order]
    area = 0.5 * sum(np.cross(poly[i], poly[(i + 1) % 4])[2] for i in range(4))
    assert area == pytest.approx(4 * A * A)
    inside = np.vstack([SQUARE, [[0.1, 0.1, 0.0]]])
    assert len(ccw_order(inside)) == 4
    tilted = SQUARE.copy()
    tilted[:, 2] = 0.2 * tilted[:, 0]
    n, _ = fit_plane(tilted)
    np.testing.assert_allclose(n, np.array([-0.2, 0, 1]) / math.hypot(0.2, 1), atol=1e-12)
    np.testing.assert_allclose(polygon_centroid(SQUARE + [1, 2, 0]), [1, 2, 0], atol=1e-12)


def test_time_to_tip_eq15():
    assert time_to_tip(20.0, -4.0, 0.0, kappa=1.0) == pytest.approx(5.0)
    # S + v t + a t^2 / 2 = 0 with S=20, v=-2, a=-4: t = (-2 + sqrt(4 + 160)) / 4
    assert time_to_tip(20.0, -2.0, -4.0, kappa=1.0) == pytest.approx((-2 + math.sqrt(164)) / 4)
    assert time_to_tip(20.0, -2.0, -4.0, kappa=0.5) == pytest.approx(0.5 * (-2 + math.sqrt(164)) / 4)
    assert time_to_tip(20.0, 1.0, 0.0) == math.inf
    det = TipDetector(threshold_deg=20.0, kappa=1.0)
    for k in range(30):
        t = 0.02 * k
        tipping = det.update(t, 30.0 - 3.0 * t - 0.5 * t * t)
    v, a = det.rates()
    assert v == pytest.approx(-3.0 - 0.58, abs=1e-6) and a == pytest.approx(-1.0, abs=1e-6)
    assert not tipping and det.update(1.0, 19.0)


def _rot(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_fasm_is_frame_independent_and_scale_free():
    # A rigid motion of the whole scene, or scaling every force and moment, leaves the
    # angles unchanged (FASM is a geometric measure of the wrench).
    rng = np.random.default_rng(11)
    for _ in range(20):
        feet = SQUARE + rng.normal(0, 0.1, (4, 3))
        com = COM + rng.normal(0, 0.2, 3)
        f, n = WEIGHT + rng.normal(0, 200, 3), rng.normal(0, 100, 3)
        ref = fasm_edges(feet, com, f, n)
        R, t = _rot(rng), rng.normal(0, 5, 3)
        moved = fasm_edges(feet @ R.T + t, R @ com + t, R @ f, R @ n)
        np.testing.assert_allclose(moved, ref, atol=1e-10)
        np.testing.assert_allclose(fasm_edges(feet, com, 7.5 * f, 7.5 * n), ref, atol=1e-10)

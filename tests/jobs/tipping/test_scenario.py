"""The per-step sensing in MuJoCo: Eq. 4 from the simulated contact forces agrees with
gravity + inertia (its left side), and the standing margins match the geometry."""

import math

import mujoco
import numpy as np
import pytest

from app.robots.heavy_hexapod import HEAVY, LEG_IDS, build_tilt_spec
from app.jobs.tipping.stability.fasm import fasm_edges, net_wrench_from_loads
from app.jobs.tipping.scenario import HexapodSim, monitor, static_tip_angle, tripod_gait_targets, CliffScenario


def _stand(stance, seconds=1.5):
    sim = HexapodSim(build_tilt_spec())
    targets = {l: HEAVY.nominal_foot(l) + (0 if l in stance else np.array([0, 0, 0.45])) for l in LEG_IDS}
    sim.place_feet(targets)
    for _ in range(int(seconds / sim.model.opt.timestep)):
        mujoco.mj_step(sim.model, sim.data)
    mujoco.mj_forward(sim.model, sim.data)
    return sim


def test_contact_wrench_matches_gravity_when_standing():
    sim = _stand([1, 3, 5])
    forces, feet, com = sim.foot_forces(), sim.feet_world(), sim.com()
    f_r = -forces.sum(axis=0)
    f_loads, _ = net_wrench_from_loads(sim.mass, sim.gravity, np.zeros(3))
    np.testing.assert_allclose(f_r, f_loads, atol=0.01 * sim.mass * 9.81)
    assert np.all(forces[[1, 3, 5], 2] == 0) and np.all(forces[[0, 2, 4], 2] > 0)
    mon = monitor(feet, forces, com, [1, 3, 5])
    # Static: FASM about each edge = atan(distance from the CoM's projection / height).
    poly = feet[[l - 1 for l in mon.polygon_legs]]
    geo = np.degrees(fasm_edges(poly, com, f_loads, np.zeros(3)))
    np.testing.assert_allclose(mon.edges_deg, geo, atol=0.5)
    h = com[2] - poly[:, 2].mean() + HEAVY.foot_radius
    assert mon.margin_deg == pytest.approx(math.degrees(math.atan(mon.ssm_m / h)), abs=1.5)
    assert mon.edge_legs == (5, 1)  # CoG 0.11 m forward: the front diagonal is closest
    assert 0 < mon.nesm_m < mon.ssm_m


def test_static_tip_angle_on_a_square():
    sq = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]])
    assert static_tip_angle(sq, np.zeros(2), 1.0, 0.0) == pytest.approx(45.0)
    assert static_tip_angle(sq, np.zeros(2), 2.0, 45.0) == pytest.approx(math.degrees(math.atan(math.sqrt(2) / 2)))


def test_tripod_gait_schedule():
    sc = CliffScenario()
    t_sw = (1 - sc.duty_factor) * sc.period_s
    _, st = tripod_gait_targets(HEAVY, sc, 1.0)
    assert st == [1, 2, 3, 4, 5, 6]  # standing
    _, st = tripod_gait_targets(HEAVY, sc, sc.stand_s + 0.5 * t_sw)
    assert st == [2, 4, 6]
    _, st = tripod_gait_targets(HEAVY, sc, sc.stand_s + t_sw + 0.1)
    assert st == [1, 2, 3, 4, 5, 6]  # duty factor > 1/2: six-leg support between swings
    _, st = tripod_gait_targets(HEAVY, sc, sc.stand_s + 0.5 * sc.period_s + 0.5 * t_sw)
    assert st == [1, 3, 5]
    # Continuity at the gait start and over a period.
    a, _ = tripod_gait_targets(HEAVY, sc, sc.stand_s - 1e-6)
    b, _ = tripod_gait_targets(HEAVY, sc, sc.stand_s + 1e-6)
    for leg in LEG_IDS:
        np.testing.assert_allclose(a[leg], b[leg], atol=1e-4)

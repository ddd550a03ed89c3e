"""The gait in MuJoCo: a walk over zones that never touches one, the unaware walk that
does, determinism."""

import numpy as np
import pytest

from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.walk import WalkConfig, stand_pose, walk
from app.robots.silo6 import SILO6
from app.jobs.freegait.terrain import Minefield, make_terrain

TERRAIN = make_terrain((-1.0, 2.5), (-1.5, 1.5), 0.04, seed=1)
ROUTE = Route(speed=0.02, distance=0.45)


@pytest.fixture(scope="module")
def blind_run():
    empty = Minefield(np.zeros((0, 2)), 0.025, 0.075)
    return walk(TERRAIN, empty, WalkConfig(route=ROUTE, aware=False))


def test_walks_the_route(blind_run):
    s = blind_run.summary()
    assert s["finished"] and s["footholds"] >= 9
    assert s["tracking_error_max_m"] < 0.05 and s["max_tilt_deg"] < 10
    pos = blind_run.steps["pos"]
    assert pos[-1, 0] - pos[0, 0] == pytest.approx(0.45, abs=0.05)  # the body really moved, in MuJoCo
    assert s["min_sm_m"] > 0.05  # SM_min held throughout


def test_zones_on_the_blind_footholds_are_avoided_when_known(blind_run):
    # Put a zone on every foothold the zone-blind planner chose after its first transfer.
    _, feet = stand_pose(SILO6, TERRAIN)
    spots = np.array([[f["x"], f["y"]] for f in blind_run.footholds[3:]])
    field = Minefield(spots, 0.025, 0.075)
    unaware = walk(TERRAIN, field, WalkConfig(route=ROUTE, aware=False))
    aware = walk(TERRAIN, field, WalkConfig(route=ROUTE, aware=True))
    su, sa = unaware.summary(), aware.summary()
    assert su["footholds_in_zones"] >= 3  # it walks into the zones it ignores
    assert sa["footholds_in_zones"] == 0 and sa["footholds"] > 0
    assert all(not f["in_zone"] for f in aware.footholds)
    assert sa["finished"]
    # Ignoring zones, the unaware planner is unaffected by them: same footholds as on an empty field.
    a = np.array([[f["x"], f["y"]] for f in unaware.footholds])
    b = np.array([[f["x"], f["y"]] for f in blind_run.footholds])
    np.testing.assert_array_equal(a, b)


def test_deterministic(blind_run):
    empty = Minefield(np.zeros((0, 2)), 0.025, 0.075)
    again = walk(TERRAIN, empty, WalkConfig(route=ROUTE, aware=False))
    for k in ("pos", "phase", "sm", "k_r", "qpos"):
        np.testing.assert_array_equal(again.steps[k], blind_run.steps[k])


def test_spinning_turns_in_place():
    r = walk(TERRAIN, Minefield(np.zeros((0, 2)), 0.025, 0.075),
             WalkConfig(route=Route(gait="spinning", speed=0.0, turn_rate_deg_s=2.0, turn_deg=20.0)))
    s = r.summary()
    assert s["finished"] and s["transfers"] >= 2
    yaw = np.degrees(r.steps["rpy"][-1][2] - r.steps["rpy"][0][2])
    assert yaw == pytest.approx(20.0, abs=4.0)
    assert np.linalg.norm(r.steps["pos"][-1, :2] - r.steps["pos"][0, :2]) < 0.05  # the COG stays put
    assert s["min_sm_m"] > 0.05


def test_circling_follows_the_arc():
    route = Route(gait="circling", speed=0.015, distance=0.3, turn_rate_deg_s=0.5)
    r = walk(TERRAIN, Minefield(np.zeros((0, 2)), 0.025, 0.075), WalkConfig(route=route))
    s = r.summary()
    assert s["finished"]
    yaw = np.degrees(r.steps["rpy"][-1][2] - r.steps["rpy"][0][2])
    assert yaw == pytest.approx(np.degrees(0.3 / (0.015 / np.radians(0.5))), abs=3.0)
    assert s["tracking_error_max_m"] < 0.05


def test_executed_subphases_take_eq_7_to_10_durations(blind_run):
    # Subphase 1 lasts H1/V1 = 1.3 s (13 periods: the search runs in the 13th); subphase 2 lasts
    # max|P1x - F_x| / V2 = R_T2 / V_BH, rounded up to the 0.1 s period; subphase 3 at most H3/V3 = 2 s.
    rows = [r for r in blind_run.transfers if not r["stopped"]]
    assert rows
    for r in rows:
        assert r["t_search"] - r["t_lift"] + 0.1 == pytest.approx(1.3)
        t2 = r["t_sub3"] - r["t_search"]
        assert r["r_t2"] / 0.02 <= t2 + 1e-9 <= r["r_t2"] / 0.02 + 0.1 + 1e-9
        assert 0.0 < r["t_touchdown"] - r["t_sub3"] <= 2.0 + 1e-9


def test_a_missed_foothold_becomes_forbidden_and_the_search_repeats():
    # The planner believes the ground 8 cm higher than it is (beyond H3/2 - I_T): some feet find
    # nothing within H3 of subphase 3. Each missed foothold becomes a forbidden point (Sec. 3.3.3),
    # the body stops (stop case 3) and the tripod is lifted and placed elsewhere.
    from app.jobs.freegait.planner.walk import MISSED_RADIUS, STOP_CAUSES

    r = walk(TERRAIN, Minefield(np.zeros((0, 2)), 0.025, 0.075),
             WalkConfig(route=Route(distance=0.3), ground_bias=0.08, stall_s=2.0))
    s = r.summary()
    assert s["failed_touchdowns"] >= 2 and len(r.missed) == s["failed_touchdowns"]
    assert s["stop_time_by_cause_s"]["touchdown_failed"] > 0
    missed = np.array(r.missed)
    # a missed point is forbidden from then on, so no later plan comes within MISSED_RADIUS of it
    d = np.linalg.norm(missed[:, None, :] - missed[None, :, :], axis=-1)
    assert d[np.triu_indices(len(missed), 1)].min() >= MISSED_RADIUS - 1e-9
    assert (r.steps["stop"] == STOP_CAUSES.index("touchdown_failed")).any()

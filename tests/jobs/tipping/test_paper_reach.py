"""Issue 28's foothold finding: the paper's footholds (|y| 1.89-1.91 m) are where the reach
boundary R lands with a swing limit near 30 deg; ours (45 deg) puts it at 2.40 m."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.jobs.tipping.reproduce.experiments import PAPER_FOOT_Y, paper_swing_limit
from app.jobs.tipping.scenario import ControllerConfig, planner_workspace
from app.jobs.tipping.stability.foothold import reachable_space
from app.robots.heavy_hexapod import HEAVY


def _R(swing_max_deg):
    ws = planner_workspace(HEAVY, 6, ControllerConfig(swing_max_deg=swing_max_deg))
    return reachable_space(ws, np.array([0.0, 0.0, 1.0]), HEAVY.nominal_foot(1), 0.9).R


def test_our_reach_and_the_papers():
    assert abs(_R(None)[1]) == pytest.approx(2.40, abs=0.01)  # the robot's own 45 deg: the published 2.40 m
    limit = paper_swing_limit()
    assert 27.8 < limit < 32.0  # just above the standing leg's swing angle
    assert abs(_R(limit)[1]) == pytest.approx(PAPER_FOOT_Y, abs=0.01)


def test_no_limit_is_the_robots_workspace():
    assert planner_workspace(HEAVY, 2, ControllerConfig()) == HEAVY.workspace(2)
    ws = planner_workspace(HEAVY, 2, ControllerConfig(swing_max_deg=30.0))
    assert ws.theta_range == (HEAVY.workspace(2).theta_range[0], math.radians(30.0))

"""The free-crab / circling / spinning gait executed in MuJoCo (Sec. 2-4 of paper 004).

The planner runs every 0.1 s (the paper's controller period) on simulated sensors only:
18 joint encoders (feet by forward kinematics), six foot switches (MuJoCo touch sensors),
body roll and pitch (the inclinometers, from the body quaternion) and the body's position
and heading (the paper's DGPS localisation; exact here). It does not know the ground: it
estimates the ground under a new foothold as the mean height of the feet in support (plus
``ground_bias``, the robustness case) and finds it by contact in subphase 3.

Each period: the foot-lifting planner (conditions 1 and 2, or the turn lifting condition),
the body motion planner (V_BH with its three stop cases, V_BV by Eq. 16, roll and pitch by
Eq. 17, the route's yaw rate), the transfer trajectories (Eq. 7-10, three subphases
synchronised per tripod), the foothold planner when a tripod has finished subphase 1; then
every foot's target in the body frame goes through the leg IK, and one ``mujoco.rollout``
call runs the period's physics steps with the joint targets ramped linearly.

Where the copy says nothing: when no candidate tripod is valid with the body moving, the
search is repeated with the body stopped for this transfer (R_T2 = R = 0 for it; the next
transfer is still planned at speed) — a body stop with cause "no_valid_tripod_at_speed";
when even that finds none the body stays stopped, and after ``stall_s`` the run ends with
cause "no_valid_tripod".

The modules: walk_config.py (settings, model, start), walk_sim.py (MuJoCo and the sensors),
walk_state.py (what the planners carry), walker.py (the control loop), walk_record.py (the
trace and the result). This module runs a walk and re-exports the names its callers use.
"""

from __future__ import annotations

import time

from app.robots.silo6 import SILO6, Silo6Geometry
from app.jobs.freegait.planner.walk_config import (MISSED_RADIUS, PHASES, STOP_CAUSES, TRIPODS0, WalkConfig, build_spec,
                                                   stand_pose, zones_near_route)
from app.jobs.freegait.planner.walk_record import WalkResult
from app.jobs.freegait.planner.walker import Walker
from app.jobs.freegait.terrain import Minefield, Terrain

__all__ = ["MISSED_RADIUS", "PHASES", "STOP_CAUSES", "TRIPODS0", "WalkConfig", "WalkResult", "build_spec", "stand_pose",
           "walk", "zones_near_route"]


def walk(terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry = SILO6,
         cancel=None) -> WalkResult:
    t_wall = time.perf_counter()
    walker = Walker(terrain, field, cfg, geom)
    k = 0
    while walker.period(k, cancel):
        k += 1
    return walker.result(t_wall)

"""What a walk is set up from (paper 004): its settings (``WalkConfig``), the MuJoCo model of
the robot on its terrain (``build_spec``), the stance it starts from (``stand_pose``), the
forbidden zones near its route, and the names shared by the planner and its record (the
tripods, the stop causes, the leg phases)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from app.jobs.freegait.planner.params import GaitParams
from app.jobs.freegait.planner.route import Route
from app.robots import silo6
from app.robots.silo6 import SILO6, Silo6Geometry
from app.jobs.freegait.terrain import Minefield, Terrain, add_heightfield, add_zone_markers

TRIPODS0 = tuple(tuple(l - 1 for l in t) for t in silo6.TRIPODS)  # leg indices 0..5, (F, C, R)
# A foothold the foot could not reach becomes a forbidden point (Sec. 3.3.3) of this radius:
# a foot (0.02 m) plus the touchdown error we measure (< 0.015 m), so the search moves on to
# the next candidate instead of clearing a mine-sized safe area around it.
MISSED_RADIUS = 0.04
STOP_CAUSES = ("", "stability", "kinematic", "touchdown_failed", "no_valid_tripod_at_speed", "no_valid_tripod")
CAUSE_INDEX = {c: i for i, c in enumerate(STOP_CAUSES)}
PHASES = ("support", "subphase1", "subphase2", "subphase3")


@dataclasses.dataclass(frozen=True)
class WalkConfig:
    route: Route = Route()
    params: GaitParams = GaitParams()
    aware: bool = True  # the planner knows the forbidden zones
    chooser: str = "ev"  # ev | random (control: a random valid tripod) | periodic (control)
    ground_bias: float = 0.0  # error of the planner's ground-height estimate, m
    friction_scale: float = 1.0
    mass_scale: float = 1.0
    timestep: float = 0.002
    control_dt: float = 0.1
    kp_vertical: float = 1.0  # Eq. 16 gain, 1/s
    kp_attitude: float = 1.0  # Eq. 17 gains, 1/s
    touch_threshold_n: float = 5.0
    settle_s: float = 0.5
    stall_s: float = 10.0
    time_limit_factor: float = 4.0
    fall_tilt_deg: float = 30.0
    seed: int = 0
    # Localisation and map errors (issue 28; 0 = exact, the default). Table 1's DGPS is
    # accurate to +-0.02 m: ``position_error_m`` is the standard deviation per axis of the
    # position the planner believes (a first-order Gauss-Markov error with time constant
    # ``position_error_tau_s``, as a DGPS error drifts over minutes); ``zone_error_m`` the
    # standard deviation per axis of each zone's surveyed centre (Sec. 5.2: measured in
    # advance with a DGPS). Footholds are counted against the true zones.
    position_error_m: float = 0.0
    position_error_tau_s: float = 60.0
    zone_error_m: float = 0.0


def build_spec(terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry = SILO6,
                markers: bool = True) -> mujoco.MjSpec:
    spec = silo6.base_spec(geom)
    spec.option.timestep = cfg.timestep
    add_heightfield(spec, terrain, friction=geom.friction * cfg.friction_scale)
    if markers:
        # the replay draws the zones near the route only (a large field holds thousands)
        add_zone_markers(spec, terrain, zones_near_route(field, cfg.route))
    silo6.add_robot(spec, dataclasses.replace(geom, friction=geom.friction * cfg.friction_scale))
    if cfg.mass_scale != 1.0:
        for b in spec.bodies:
            for gm in b.geoms:
                if gm.mass > 0:
                    gm.mass = gm.mass * cfg.mass_scale
    return spec


def zones_near_route(field: Minefield, route: Route, reach: float = 1.5) -> Minefield:
    """The zones within ``reach`` of the route's nominal COG path (a foot never goes farther)."""
    if len(field.centres) == 0:
        return field
    path = route.nominal_path()[::10, :2]
    d = np.linalg.norm(field.centres[:, None, :] - path[None, :, :], axis=-1).min(axis=1)
    return Minefield(field.centres[d < reach], field.zone_radius, field.safe_radius)


def stand_pose(geom: Silo6Geometry, terrain: Terrain) -> tuple[np.ndarray, np.ndarray]:
    """Initial body position and body-frame feet: nominal footholds on the ground."""
    feet = geom.nominal_feet()
    ground = terrain.height(feet[:, :2]) + geom.foot_radius
    z0 = float(ground.mean() + geom.stand_height)
    feet = feet.copy()
    feet[:, 2] = ground - z0
    return np.array([0.0, 0.0, z0]), feet

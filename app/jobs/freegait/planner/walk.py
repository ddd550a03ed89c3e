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
"""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np
from mujoco import rollout

from app.jobs.freegait.planner.geometry import Motion, kinematic_margin, polygon_margin, transfer_points, triangle_margin
from app.jobs.freegait.planner.params import GaitParams, nominal_re, r1
from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.search import SearchInput, SearchResult, candidate_grid, evaluate, search
from app.robots import silo6
from app.robots.silo6 import SENSOR_SLICES, SILO6, Silo6Geometry
from app.jobs.freegait.terrain import Minefield, Terrain, add_heightfield, add_zone_markers

TRIPODS0 = tuple(tuple(l - 1 for l in t) for t in silo6.TRIPODS)  # leg indices 0..5, (F, C, R)
# A foothold the foot could not reach becomes a forbidden point (Sec. 3.3.3) of this radius:
# a foot (0.02 m) plus the touchdown error we measure (< 0.015 m), so the search moves on to
# the next candidate instead of clearing a mine-sized safe area around it.
MISSED_RADIUS = 0.04
STOP_CAUSES = ("", "stability", "kinematic", "touchdown_failed", "no_valid_tripod_at_speed", "no_valid_tripod")
_CAUSE = {c: i for i, c in enumerate(STOP_CAUSES)}
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


def _rot(q: np.ndarray) -> np.ndarray:
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, q)
    return m.reshape(3, 3)


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rp(roll: float, pitch: float) -> np.ndarray:
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return ry @ rx


@dataclasses.dataclass
class WalkResult:
    steps: dict[str, np.ndarray]  # per control period
    transfers: list[dict]  # one row per tripod transfer
    footholds: list[dict]  # one row per touchdown
    outcome: str  # finished | fallen | no_valid_tripod | time_limit
    model_xml: str
    sim_steps: int
    wall_s: float
    searches: int
    missed: list = dataclasses.field(default_factory=list)  # footholds that became forbidden (world xy)

    def summary(self) -> dict:
        """Numbers of the walk; a value that cannot exist (no transfer, no zone) is None, never NaN."""
        out = self._summary()
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}

    def _summary(self) -> dict:
        s = self.steps
        dt = float(s["t"][1] - s["t"][0]) if len(s["t"]) > 1 else 0.1
        moving = s["t"] > 0
        n_zone = sum(1 for f in self.footholds if f["in_zone"])
        n_safe = sum(1 for f in self.footholds if f["in_safe_area"])
        stop = s["stop"][moving] > 0
        sup = [tr for tr in self.transfers if tr.get("support_s") is not None]
        dev = [math.hypot(f["x"] - f["planned_x"], f["y"] - f["planned_y"]) for f in self.footholds
               if f["planned_x"] is not None]
        return {
            "outcome": self.outcome,
            "finished": self.outcome == "finished",
            "time_s": float(s["t"][-1]),
            "distance_m": float(s["progress"][-1]),
            "mean_speed_m_s": float(s["progress"][-1] / max(s["t"][-1], 1e-9)),
            "footholds": len(self.footholds),
            "footholds_in_zones": n_zone,
            "footholds_in_safe_areas": n_safe,
            "closest_zone_m": min((f["zone_distance"] for f in self.footholds if f["zone_distance"] is not None),
                                  default=None),
            "foothold_error_max_m": max(dev, default=0.0),  # touchdown vs planned F' (Eq. 18)
            "transfers": len(self.transfers),
            "failed_touchdowns": len(self.missed),
            "stop_time_s": float(stop.sum() * dt),
            "stop_time_by_cause_s": {c: float(((s["stop"] == i) & moving).sum() * dt) for i, c in enumerate(STOP_CAUSES) if i},
            "min_sm_m": float(np.nanmin(s["sm"][moving])) if moving.any() else float("nan"),
            "mean_sm_m": float(np.nanmean(s["sm"][moving])) if moving.any() else float("nan"),
            "min_k_r_m": float(np.nanmin(s["k_r"][moving])) if moving.any() else float("nan"),
            "tracking_error_max_m": float(np.max(s["track_err"])),
            "tracking_error_final_m": float(s["track_err"][-1]),
            "max_tilt_deg": float(np.degrees(np.max(np.abs(s["rpy"][:, :2])))),
            "mean_transfer_s": float(np.mean([tr["transfer_s"] for tr in self.transfers if tr.get("transfer_s")] or [np.nan])),
            "mean_support_s": float(np.mean([tr["support_s"] for tr in sup] or [np.nan])),
            "searches": self.searches,
            "sim_steps": self.sim_steps,
            "wall_s": self.wall_s,
        }


def stand_pose(geom: Silo6Geometry, terrain: Terrain) -> tuple[np.ndarray, np.ndarray]:
    """Initial body position and body-frame feet: nominal footholds on the ground."""
    feet = geom.nominal_feet()
    ground = terrain.height(feet[:, :2]) + geom.foot_radius
    z0 = float(ground.mean() + geom.stand_height)
    feet = feet.copy()
    feet[:, 2] = ground - z0
    return np.array([0.0, 0.0, z0]), feet


def walk(terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry = SILO6,
         cancel=None) -> WalkResult:
    t_wall = time.perf_counter()
    walker = _Walker(terrain, field, cfg, geom)
    k = 0
    while walker.period(k, cancel):
        k += 1
    return walker.result(t_wall)


def _world_xy(pos: np.ndarray, yaw: float, p: np.ndarray) -> np.ndarray:
    """Body-frame (horizontal) points ``p[..., :2]`` in world xy, the body at ``pos`` with ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.stack([pos[0] + c * p[..., 0] - s * p[..., 1], pos[1] + s * p[..., 0] + c * p[..., 1]], -1)


class _Sim:
    """The MuJoCo side of a walk: the robot on its terrain, standing on its nominal footholds,
    advanced one control period per ``mujoco.rollout`` call (the planner only sees sensors)."""

    def __init__(self, terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry,
                 pos0: np.ndarray, q0: np.ndarray):
        spec = build_spec(terrain, field, cfg, geom)
        self.model = spec.compile()
        self.xml = spec.to_xml()
        self.data = mujoco.MjData(self.model)
        self.nsub = int(round(cfg.control_dt / cfg.timestep))
        self.data.qpos[:3] = pos0
        self.data.qpos[3] = 1.0
        self.data.qpos[7:] = q0
        self.data.ctrl[:] = q0
        mujoco.mj_forward(self.model, self.data)
        state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.zeros(mujoco.mj_stateSize(self.model, state_spec))
        mujoco.mj_getState(self.model, self.data, self.state, state_spec)
        self.roller = rollout.Rollout(nthread=0)
        self.sim_steps = 0

    def period(self, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
        """One control period with the joint targets ramped linearly; its sensor rows."""
        u = (np.arange(1, self.nsub + 1) / self.nsub)[:, None]
        ctrl = (q_from[None, :] * (1 - u) + q_to[None, :] * u)[None]
        st, sens = self.roller.rollout(self.model, self.data, self.state[None], ctrl, nstep=self.nsub)
        self.state = st[0, -1].copy()
        self.sim_steps += self.nsub
        return sens[0]


@dataclasses.dataclass
class _Sensors:
    """One period's readings: foot switches, joint encoders (feet by forward kinematics),
    the inclinometers' roll and pitch, and the localisation's position and heading."""

    touch: np.ndarray  # per leg, the largest contact force over the period
    pos: np.ndarray
    roll: float
    pitch: float
    yaw: float
    feet_h: np.ndarray  # (6, 3) feet in the horizontal frame (yaw removed, roll and pitch kept)
    tips_w: np.ndarray  # (6, 3) feet in the world, for the record and the footholds

    @classmethod
    def read(cls, sens: np.ndarray, geom: Silo6Geometry) -> _Sensors:
        last = sens[-1]
        touch = sens[:, SENSOR_SLICES["touch"]].max(axis=0)
        q = last[SENSOR_SLICES["joints"]].reshape(6, 3)
        r_wb = _rot(last[SENSOR_SLICES["quat"]])
        pos = last[SENSOR_SLICES["pos"]]
        yaw = math.atan2(r_wb[1, 0], r_wb[0, 0])
        r_h = _rz(-yaw) @ r_wb
        pitch = math.asin(max(-1.0, min(1.0, -r_h[2, 0])))
        roll = math.atan2(r_h[2, 1], r_h[2, 2])
        feet_h = (r_h @ silo6.leg_fk_body(geom, q).T).T
        return cls(touch, pos, roll, pitch, yaw, feet_h, last[SENSOR_SLICES["tips"]].reshape(6, 3))


@dataclasses.dataclass
class _Allowed:
    """The foothold test handed to the search: a body-frame point is allowed when it lies
    outside every safe area (only if the planner knows the zones) and clear of every missed
    foothold. Seen from where the body is at the search."""

    pos: np.ndarray
    yaw: float
    local: Minefield  # the zones within reach of a foot from ``pos``
    safe_radius: float
    aware: bool
    missed: np.ndarray

    @classmethod
    def at(cls, field: Minefield, aware: bool, missed: list[np.ndarray], pos_xy: np.ndarray, yaw: float) -> _Allowed:
        pts = np.array(missed) if missed else np.zeros((0, 2))
        # only zones within reach of a foot can matter (candidates lie within 0.9 m of the body centre)
        near = field.centres[np.linalg.norm(field.centres - pos_xy[:2], axis=1) < 1.2] if len(field.centres) else field.centres
        return cls(pos_xy, yaw, Minefield(near, field.zone_radius, field.safe_radius), field.safe_radius, aware, pts)

    def __call__(self, p: np.ndarray) -> np.ndarray:
        w = _world_xy(self.pos, self.yaw, p)
        ok = np.ones(w.shape[:-1], dtype=bool)
        if self.aware:
            ok &= self.local.distance(w) >= self.safe_radius
        if len(self.missed):
            ok &= np.linalg.norm(w[..., None, :] - self.missed, axis=-1).min(axis=-1) >= MISSED_RADIUS
        return ok


@dataclasses.dataclass
class _Transfer:
    """The tripod in transfer (one at a time): its subphase and what its foothold search set."""

    tri: int  # 0 or 1
    legs: list[int]
    t_lift: float
    row: dict  # its history row, filled in as the transfer goes
    sub: int = 1
    tau: float = 0.0  # time in the subphase
    rise: float = 0.0  # subphase 1 height so far
    stopped: bool = False  # the body stops for this transfer (no tripod valid at speed)
    failed_legs: int = 0
    hold: int = 0  # a stop cause while the tripod waits (touchdown_failed, no_valid_tripod); 0: none
    p1: np.ndarray | None = None  # commanded feet at the end of subphase 1
    F: np.ndarray | None = None  # the chosen footholds, body frame
    est: float = 0.0  # the planner's estimate of the ground height under them
    t2: np.ndarray | None = None  # each foot's subphase 2 duration
    desc: np.ndarray | None = None  # subphase 3 descent so far, per foot
    touched: np.ndarray | None = None
    planned_w: np.ndarray | None = None  # F' in the world (None without a search: periodic)


@dataclasses.dataclass
class _GaitState:
    """What the planners carry from one control period to the next."""

    phase: np.ndarray  # per leg, an index of PHASES
    p_cmd: np.ndarray  # commanded feet in the horizontal frame (support: ground-fixed)
    cmd_xy: np.ndarray  # where the route says the body should be
    alpha: float  # crab angle in use
    transfer: _Transfer | None = None
    progress: float = 0.0
    yaw_turned: float = 0.0
    cmd_yaw: float = 0.0
    stall: float = 0.0  # time waiting for a valid tripod
    searches: int = 0
    outcome: str = "time_limit"
    missed: list[np.ndarray] = dataclasses.field(default_factory=list)  # world xy of missed footholds
    transfers: list[dict] = dataclasses.field(default_factory=list)
    footholds: list[dict] = dataclasses.field(default_factory=list)
    last_touchdown: dict[int, float] = dataclasses.field(default_factory=lambda: {0: 0.0, 1: 0.0})
    lifted_before: set[int] = dataclasses.field(default_factory=set)


@dataclasses.dataclass
class _Period:
    """One control period: the readings, the margins the planners decide on, and the body
    motion chosen."""

    t: float
    s: _Sensors
    params: GaitParams  # with this period's k_ev
    motion: Motion
    re: float
    kl: np.ndarray  # kinematic margin per leg
    support: np.ndarray  # legs in support when the period began
    k_r: float
    sm: float
    cause: int = 0  # index of STOP_CAUSES
    v: float = 0.0
    w: float = 0.0
    v_bv: float = 0.0
    roll_des: float = 0.0
    pitch_des: float = 0.0


class _Recorder:
    """The walk's trace, one row per control period."""

    KEYS = ("t", "pos", "rpy", "phase", "sm", "k_r", "v", "stop", "progress", "cmd_xy", "track_err", "k_ev", "crab_deg",
            "qpos", "tips")

    def __init__(self):
        self.cols: dict[str, list] = {k: [] for k in self.KEYS}

    def row(self, p: _Period, g: _GaitState, sim: _Sim, cause: int | None = None) -> None:
        c, s = self.cols, p.s
        c["t"].append(p.t)
        c["pos"].append(np.array(s.pos))
        c["rpy"].append((s.roll, s.pitch, s.yaw))
        c["phase"].append(g.phase.copy())
        c["sm"].append(p.sm if np.isfinite(p.sm) else np.nan)
        c["k_r"].append(p.k_r)
        c["v"].append(p.v)
        c["stop"].append(p.cause if cause is None else cause)
        c["progress"].append(g.progress)
        c["cmd_xy"].append(g.cmd_xy.copy())
        c["track_err"].append(float(np.linalg.norm(np.asarray(s.pos[:2]) - g.cmd_xy)))
        c["k_ev"].append(p.params.k_ev)
        c["crab_deg"].append(math.degrees(g.alpha))
        c["qpos"].append(sim.state[1:1 + sim.model.nq].copy())
        c["tips"].append(s.tips_w.copy())

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.cols.items()}


class _Walker:
    """One walk: every control period the foot-lifting planner, the body motion planner,
    the transfer subphases (the foothold planner at the end of subphase 1), the joint
    targets, then the period's physics."""

    def __init__(self, terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry):
        self.cfg, self.geom, self.field = cfg, geom, field
        self.route, self.base = cfg.route, cfg.params
        self.rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), 0xF6A1]))
        self.dt = cfg.control_dt
        self.rects = geom.workspaces()
        self.zlo = geom.z_range[0]
        pos0, feet0 = stand_pose(geom, terrain)
        self.q_cmd = silo6.leg_ik_body(geom, feet0).reshape(-1)
        self.sim = _Sim(terrain, field, cfg, geom, pos0, self.q_cmd)
        self.sens = None
        for _ in range(int(round(cfg.settle_s / self.dt))):  # settle on the initial stance
            self.sens = self.sim.period(self.q_cmd, self.q_cmd)
        self.g = _GaitState(phase=np.zeros(6, dtype=int), p_cmd=feet0.copy(), cmd_xy=np.array(pos0[:2]),
                            alpha=self.route.crab_angle(0.0))
        self.rec = _Recorder()
        self.known, self.loc_err, self.err_rng = field, np.zeros(2), None
        if cfg.position_error_m > 0 or cfg.zone_error_m > 0:  # its own stream: the exact walk draws nothing
            self.err_rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), 0xD695]))
            if cfg.zone_error_m > 0 and len(field.centres):
                self.known = Minefield(field.centres + self.err_rng.normal(0.0, cfg.zone_error_m, field.centres.shape),
                                       field.zone_radius, field.safe_radius)
            self.loc_err = self.err_rng.normal(0.0, cfg.position_error_m, 2)
        self.t_limit = self.route.nominal_duration() * cfg.time_limit_factor + 30.0
        self.v_nom, self.omega_nom = self.route.body_speed, self.route.omega

    def period(self, k: int, cancel) -> bool:
        """Control period ``k``; False when the walk has ended (``g.outcome`` says how)."""
        t = k * self.dt
        if cancel is not None and k % 50 == 0 and cancel():
            self.g.outcome = "cancelled"
            return False
        s = _Sensors.read(self.sens, self.geom)
        if self.ended(t, s):
            return False
        self.localise()
        p = self.margins(t, s)
        if self.g.transfer is None:
            self.lift_feet(p)
        self.move_body(p)
        if self.g.transfer is not None and not self.transfer_step(p):
            return False
        q_new = self.joint_targets(p)
        self.follow_route(p)
        self.rec.row(p, self.g, self.sim)
        self.sens = self.sim.period(self.q_cmd, q_new)
        self.q_cmd = q_new
        return True

    def localise(self) -> None:
        """One control period of the localisation error (Gauss-Markov, stationary spread
        ``position_error_m`` per axis)."""
        if self.err_rng is not None and self.cfg.position_error_m > 0:
            a = math.exp(-self.dt / self.cfg.position_error_tau_s)
            self.loc_err = a * self.loc_err + math.sqrt(1 - a * a) * self.err_rng.normal(0.0, self.cfg.position_error_m, 2)

    def believed(self, pos: np.ndarray) -> np.ndarray:
        """Where the planner believes the body is (horizontal): the true position plus the
        localisation error."""
        return np.asarray(pos[:2]) + self.loc_err

    def ended(self, t: float, s: _Sensors) -> bool:
        cfg, route, g = self.cfg, self.route, self.g
        if abs(s.roll) > math.radians(cfg.fall_tilt_deg) or abs(s.pitch) > math.radians(cfg.fall_tilt_deg) or s.pos[2] < 0.12:
            g.outcome = "fallen"
            return True
        done = (g.yaw_turned >= abs(math.radians(route.turn_deg))) if route.gait == "spinning" else (g.progress >= route.distance)
        if done:
            g.outcome = "finished"
            return True
        return t > self.t_limit

    def margins(self, t: float, s: _Sensors) -> _Period:
        g = self.g
        if g.transfer is None:
            g.alpha = self.route.crab_angle(t)  # a new crab angle takes effect between transfers (Figs. 11-12)
        params = dataclasses.replace(self.base, k_ev=self.route.k_ev(t, self.base.k_ev))
        motion = Motion(self.v_nom, g.alpha, self.omega_nom)
        rr1 = r1(motion, params)
        re = nominal_re(motion, params, self.geom.stroke)
        kl = kinematic_margin(s.feet_h[:, :2], self.rects, motion, rr1)
        support = g.phase == 0
        k_r = float(kl[support].min()) if support.any() else float("nan")
        sm = polygon_margin(s.feet_h[support, :2]) if support.sum() >= 3 else -math.inf
        return _Period(t, s, params, motion, re, kl, support, k_r, sm)

    # -- foot-lifting planner (both tripods in support) -----------------------------------

    def lift_feet(self, p: _Period) -> None:
        ktri = [float(p.kl[list(tr)].min()) for tr in TRIPODS0]
        lift_t = int(np.argmin(ktri)) if ktri[0] != ktri[1] else 1  # tie: tripod 2 first (Sec. 5.1)
        if self.should_lift(p, ktri, lift_t):
            legs = list(TRIPODS0[lift_t])
            self.g.transfer = _Transfer(tri=lift_t, legs=legs, t_lift=p.t, row={"tripod": lift_t + 1, "t_lift": round(p.t, 3)})
            self.g.phase[legs] = 1

    def should_lift(self, p: _Period, ktri: list[float], lift_t: int) -> bool:
        if p.motion.kind == "spinning" or self.cfg.chooser == "periodic":
            return p.t - self.g.last_touchdown[1 - lift_t] >= 0.0  # turn lifting condition / periodic alternation
        fo = p.s.feet_h[list(TRIPODS0[1 - lift_t]), :2]
        _, l_other, _ = transfer_points(fo[0], fo[1], fo[2], p.motion, p.re)
        sm_other = float(triangle_margin(fo[0], fo[1], fo[2]))
        if np.isfinite(l_other) and l_other <= 0.0:
            return True  # foot-lifting condition 1: L = 0
        return ktri[lift_t] <= 0.0 and sm_other > p.params.sm_min  # foot-lifting condition 2

    # -- body motion planner ---------------------------------------------------------------

    def move_body(self, p: _Period) -> None:
        """V_BH with its stop cases, V_BV (Eq. 16), roll and pitch (Eq. 17), then the
        ground-fixed motion of every foot not in subphase 2 (support, rising, descending)."""
        cfg, geom, g, s, dt = self.cfg, self.geom, self.g, p.s, self.dt
        p.cause = self.stop_cause(p)
        p.v = 0.0 if p.cause else self.v_nom
        p.w = 0.0 if p.cause else self.omega_nom
        rects = self.rects
        inside = all(rects[i, 0] <= s.feet_h[i, 0] <= rects[i, 1] and rects[i, 2] <= s.feet_h[i, 1] <= rects[i, 3]
                     for i in np.flatnonzero(p.support))
        height = -float(s.feet_h[p.support, 2].mean()) if p.support.any() else geom.stand_height
        p.v_bv = cfg.kp_vertical * (geom.stand_height - height) if inside else 0.0
        p.roll_des = s.roll * (1.0 - cfg.kp_attitude * dt) if inside else s.roll
        p.pitch_des = s.pitch * (1.0 - cfg.kp_attitude * dt) if inside else s.pitch
        d = np.array([math.cos(g.alpha), math.sin(g.alpha)])
        rz = _rz(-p.w * dt)[:2, :2]
        fixed = g.phase != 2
        g.p_cmd[fixed, :2] = (g.p_cmd[fixed, :2] - p.v * dt * d) @ rz.T
        g.p_cmd[fixed, 2] -= p.v_bv * dt

    def stop_cause(self, p: _Period) -> int:
        tr = self.g.transfer
        if tr is not None and tr.hold:
            return tr.hold
        if tr is not None and tr.stopped:
            return _CAUSE["no_valid_tripod_at_speed"]
        if p.support.sum() >= 3 and p.sm <= p.params.sm_min and p.motion.kind != "spinning":
            return _CAUSE["stability"]
        if p.support.any() and p.k_r <= 0.0:
            return _CAUSE["kinematic"]
        return 0

    # -- transfer phase: three subphases, synchronised per tripod --------------------------

    def transfer_step(self, p: _Period) -> bool:
        """False when the walk ends here (no valid tripod for ``stall_s``)."""
        tr = self.g.transfer
        tr.tau += self.dt
        if tr.sub == 1:
            return self.rise(p, tr)
        if tr.sub == 2:
            self.swing(p, tr)
        else:
            self.descend(p, tr)
        return True

    def rise(self, p: _Period, tr: _Transfer) -> bool:
        """Subphase 1: straight up by H1 at V1; at P_1 the foothold planner runs."""
        step = min(p.params.v1 * self.dt, p.params.h1 - tr.rise)
        self.g.p_cmd[tr.legs, 2] += step
        tr.rise += step
        if tr.rise >= p.params.h1 - 1e-9:
            return self.plan_footholds(p, tr)
        return True

    def plan_footholds(self, p: _Period, tr: _Transfer) -> bool:
        g = self.g
        sup_legs = list(TRIPODS0[1 - tr.tri])
        chosen, res = self.choose_footholds(p, tr, sup_legs)
        if chosen is None:
            tr.hold = _CAUSE["no_valid_tripod"]
            g.stall += self.dt
            if g.stall >= self.cfg.stall_s:
                g.outcome = "no_valid_tripod"
                self.rec.row(p, g, self.sim, cause=tr.hold)
                return False
            return True
        g.stall = 0.0
        tr.hold = 0
        est = float(p.s.feet_h[sup_legs, 2].mean()) + self.cfg.ground_bias
        dx = np.abs(chosen[:, 0] - p.s.feet_h[tr.legs, 0])
        tr.sub, tr.tau, tr.p1, tr.F, tr.est = 2, 0.0, g.p_cmd[tr.legs].copy(), chosen.copy(), est
        tr.t2, tr.desc, tr.touched = np.maximum(dx / p.params.v2, self.dt), np.zeros(3), np.zeros(3, bool)
        tr.row.update(t_search=round(p.t, 3), stopped=tr.stopped)
        if res is not None:
            tr.row.update(ev=res.ev, k=res.k, sm_t=res.sm_t, l=res.l, r_t2=res.r_t2, valid=res.counts["valid"],
                          index=list(res.index))
            tr.planned_w = _world_xy(self.believed(p.s.pos), p.s.yaw, res.ground_points)
        g.phase[tr.legs] = 2
        return True

    def choose_footholds(self, p: _Period, tr: _Transfer, sup_legs: list[int]):
        """(footholds or None, the search's result or None): the best valid tripod by Ev, a
        random valid one (control), or the periodic control's fixed points (no search)."""
        n = p.params.n_candidates
        cand = np.stack([candidate_grid(self.rects[l], p.motion.local_direction(self.geom.workspace_centre(l + 1)),
                                        n, p.params) for l in tr.legs])
        if self.cfg.chooser == "periodic":
            return cand[:, -1 if n < 6 else -2], None
        inp = SearchInput(p.motion, p.params, cand, p.s.feet_h[tr.legs, :2], self.rects[tr.legs],
                          float(p.kl[sup_legs].min()), p.re,
                          _Allowed.at(self.known, self.cfg.aware, self.g.missed, self.believed(p.s.pos), p.s.yaw))
        pick = self.rng if self.cfg.chooser == "random" else None
        res = search(inp, pick)
        self.g.searches += 1
        if not res.found:
            # the same search with the body stopped for this transfer
            res0 = _search_stopped(inp, pick)
            self.g.searches += 1
            if res0 is not None and res0.found:
                tr.stopped = True
                res = res0
        return (res.footholds if res.found else None), res

    def swing(self, p: _Period, tr: _Transfer) -> None:
        """Subphase 2: to above F on the line to the estimated ground + H3/2, never below
        the estimate + H2 (1 - u)."""
        p_cmd, tau = self.g.p_cmd, tr.tau
        z2 = tr.est + p.params.h3 / 2
        for n_, l in enumerate(tr.legs):
            u = min(tau / tr.t2[n_], 1.0)
            p1 = tr.p1[n_]
            p_cmd[l, :2] = p1[:2] + u * (tr.F[n_] - p1[:2])
            line = p1[2] + u * (z2 - p1[2])
            p_cmd[l, 2] = max(line, tr.est + p.params.h2 * (1.0 - u))
        if tau >= tr.t2.max() - 1e-9:
            tr.sub, tr.tau = 3, 0.0
            tr.row["t_sub3"] = round(p.t, 3)
            self.g.phase[tr.legs] = 3

    def descend(self, p: _Period, tr: _Transfer) -> None:
        """Subphase 3: down at V3 until each foot switch closes, at most H3."""
        g = self.g
        for n_, l in enumerate(tr.legs):
            if tr.touched[n_]:
                continue
            if p.s.touch[l] > self.cfg.touch_threshold_n:
                tr.touched[n_] = True
                g.p_cmd[l] = p.s.feet_h[l]  # hold where the switch closed
                g.phase[l] = 0
                continue
            step = p.params.v3 * self.dt
            g.p_cmd[l, 2] -= step
            tr.desc[n_] += step
        resolved = tr.touched | (tr.desc >= p.params.h3 - 1e-9) | (g.p_cmd[tr.legs, 2] < self.zlo)
        if resolved.all():
            if tr.touched.all():
                self.touch_down(p, tr)
            else:
                self.missed_touchdown(p, tr)

    def touch_down(self, p: _Period, tr: _Transfer) -> None:
        g, t = self.g, p.t
        tr.row.update(t_touchdown=round(t, 3), transfer_s=round(t - tr.t_lift, 3), failed_legs=tr.failed_legs)
        # the tripod's support phase before this transfer (none before the first lift)
        first = tr.tri not in g.lifted_before
        tr.row["support_s"] = None if first else round(tr.t_lift - g.last_touchdown[tr.tri], 3)
        g.lifted_before.add(tr.tri)
        g.footholds += [self.foothold(p, tr, n_, l) for n_, l in enumerate(tr.legs)]
        g.last_touchdown[tr.tri] = t
        g.transfers.append(tr.row)
        g.phase[tr.legs] = 0
        g.transfer = None

    def foothold(self, p: _Period, tr: _Transfer, n_: int, l: int) -> dict:
        xy = p.s.tips_w[l, :2]
        planned, field = tr.planned_w, self.field
        return {
            "t": round(p.t, 3), "leg": l + 1, "tripod": tr.tri + 1,
            "x": float(xy[0]), "y": float(xy[1]), "z": float(p.s.tips_w[l, 2]),
            "planned_x": float(planned[n_, 0]) if planned is not None else None,
            "planned_y": float(planned[n_, 1]) if planned is not None else None,
            "zone_distance": float(field.distance(xy)) if len(field.centres) else None,
            "in_zone": bool(field.in_zone(xy)), "in_safe_area": bool(field.in_safe_area(xy)),
        }

    def missed_touchdown(self, p: _Period, tr: _Transfer) -> None:
        """Sec. 3.3.3: the missed footholds become forbidden; lift again and search anew."""
        g = self.g
        for n_, l in enumerate(tr.legs):
            if not tr.touched[n_]:
                xy = tr.planned_w[n_] if tr.planned_w is not None else _world_xy(self.believed(p.s.pos), p.s.yaw,
                                                                                  p.s.feet_h[l, :2])
                g.missed.append(np.asarray(xy, dtype=float))
        tr.failed_legs += int((~tr.touched).sum())
        tr.sub, tr.tau, tr.rise, tr.hold = 1, 0.0, 0.0, _CAUSE["touchdown_failed"]
        g.phase[tr.legs] = 1

    # -- the period's commands --------------------------------------------------------------

    def joint_targets(self, p: _Period) -> np.ndarray:
        r_des = _rp(p.roll_des, p.pitch_des)
        feet_b = (r_des.T @ self.g.p_cmd.T).T
        return silo6.leg_ik_body(self.geom, feet_b).reshape(-1)

    def follow_route(self, p: _Period) -> None:
        """The commanded path the body should follow (tracking error, the end of the route)."""
        g, dt = self.g, self.dt
        g.cmd_xy = g.cmd_xy + p.v * dt * np.array([math.cos(g.cmd_yaw + g.alpha), math.sin(g.cmd_yaw + g.alpha)])
        g.cmd_yaw += p.w * dt
        g.progress += p.v * dt
        g.yaw_turned += abs(p.w) * dt

    def result(self, t_wall: float) -> WalkResult:
        g = self.g
        return WalkResult(steps=self.rec.arrays(), transfers=g.transfers, footholds=g.footholds, outcome=g.outcome,
                          model_xml=self.sim.xml, sim_steps=self.sim.sim_steps, wall_s=time.perf_counter() - t_wall,
                          searches=g.searches, missed=[m.tolist() for m in g.missed])


def _search_stopped(inp: SearchInput, pick):
    """Support conditions with the body stopped during this transfer: its R_T2, R_3 and R
    are zero (so conditions 2, 4 and 6 lose those terms and F' = F), while K keeps the R_1
    of the next lift at speed and R_e stays the nominal one (the next transfer is at speed)."""
    e = evaluate(inp)
    conds = dict(e["conds"])
    if "c2_support_margin" in conds:
        conds["c1_zones"] = _zones_unshifted(inp)
        conds["c2_support_margin"] = e["l"] < inp.k_support
        conds["c4_touchdown"] = e["l"] > 0.0  # this transfer's R_3 is zero too
        conds["c6_displacement"] = np.ones_like(conds["c6_displacement"])
    else:
        conds["t1_zones"] = _zones_unshifted(inp)
        conds["t4_turn"] = np.ones_like(conds["t4_turn"])
    valid = np.logical_and.reduce(list(conds.values()))
    if not valid.any():
        return None
    flat = int(np.argmax(np.where(valid, e["ev"], -np.inf))) if pick is None else int(pick.choice(np.flatnonzero(valid)))
    a, b, c = (int(x) for x in np.unravel_index(flat, valid.shape))
    cand = inp.candidates
    fh = np.stack([cand[0, a], cand[1, b], cand[2, c]])
    counts = {n: int(v.sum()) for n, v in conds.items()}
    counts["valid"] = int(valid.sum())
    return SearchResult(True, (a, b, c), fh, fh.copy(), float(e["ev"][a, b, c]), float(e["k"][a, b, c]),
                        float(e["sm_t"][a, b, c]), float(e["l"][a, b, c]), 0.0, counts)


def _zones_unshifted(inp: SearchInput) -> np.ndarray:
    cand = inp.candidates
    ok = np.ones(cand.shape[:2], dtype=bool) if inp.allowed is None else np.asarray(inp.allowed(cand), dtype=bool)
    return ok[0][:, None, None] & ok[1][None, :, None] & ok[2][None, None, :]

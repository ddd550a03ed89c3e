"""What the walk's planners decide on and carry (paper 004): one control period's readings and
margins (``Period``), the state carried from one period to the next (``GaitState``), the
tripod in transfer (``Transfer``) and the foothold test handed to the search
(``AllowedFootholds``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.freegait.planner.geometry import Motion
from app.jobs.freegait.planner.params import GaitParams
from app.jobs.freegait.planner.walk_config import MISSED_RADIUS
from app.jobs.freegait.planner.walk_sim import Sensors, world_xy
from app.jobs.freegait.terrain import Minefield


@dataclasses.dataclass
class AllowedFootholds:
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
    def at(cls, field: Minefield, aware: bool, missed: list[np.ndarray], pos_xy: np.ndarray, yaw: float) -> AllowedFootholds:
        pts = np.array(missed) if missed else np.zeros((0, 2))
        # only zones within reach of a foot can matter (candidates lie within 0.9 m of the body centre)
        near = field.centres[np.linalg.norm(field.centres - pos_xy[:2], axis=1) < 1.2] if len(field.centres) else field.centres
        return cls(pos_xy, yaw, Minefield(near, field.zone_radius, field.safe_radius), field.safe_radius, aware, pts)

    def __call__(self, p: np.ndarray) -> np.ndarray:
        w = world_xy(self.pos, self.yaw, p)
        ok = np.ones(w.shape[:-1], dtype=bool)
        if self.aware:
            ok &= self.local.distance(w) >= self.safe_radius
        if len(self.missed):
            ok &= np.linalg.norm(w[..., None, :] - self.missed, axis=-1).min(axis=-1) >= MISSED_RADIUS
        return ok


@dataclasses.dataclass
class Transfer:
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
class GaitState:
    """What the planners carry from one control period to the next."""

    phase: np.ndarray  # per leg, an index of PHASES
    p_cmd: np.ndarray  # commanded feet in the horizontal frame (support: ground-fixed)
    cmd_xy: np.ndarray  # where the route says the body should be
    alpha: float  # crab angle in use
    transfer: Transfer | None = None
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
class Period:
    """One control period: the readings, the margins the planners decide on, and the body
    motion chosen."""

    t: float
    s: Sensors
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

"""The MuJoCo side of a walk (paper 004): the robot on its terrain advanced one control period
per ``mujoco.rollout`` call (``WalkSim``), and what the planner reads of it (``Sensors``:
foot switches, joint encoders, inclinometers, localisation); the frame helpers both use."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
from mujoco import rollout

from app.jobs.freegait.planner.walk_config import WalkConfig, build_spec
from app.robots import silo6
from app.robots.silo6 import SENSOR_SLICES, Silo6Geometry
from app.jobs.freegait.terrain import Minefield, Terrain


def quat_matrix(q: np.ndarray) -> np.ndarray:
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, q)
    return m.reshape(3, 3)


def yaw_matrix(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def roll_pitch_matrix(roll: float, pitch: float) -> np.ndarray:
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return ry @ rx


def world_xy(pos: np.ndarray, yaw: float, p: np.ndarray) -> np.ndarray:
    """Body-frame (horizontal) points ``p[..., :2]`` in world xy, the body at ``pos`` with ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.stack([pos[0] + c * p[..., 0] - s * p[..., 1], pos[1] + s * p[..., 0] + c * p[..., 1]], -1)


class WalkSim:
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
class Sensors:
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
    def read(cls, sens: np.ndarray, geom: Silo6Geometry) -> Sensors:
        last = sens[-1]
        touch = sens[:, SENSOR_SLICES["touch"]].max(axis=0)
        q = last[SENSOR_SLICES["joints"]].reshape(6, 3)
        r_wb = quat_matrix(last[SENSOR_SLICES["quat"]])
        pos = last[SENSOR_SLICES["pos"]]
        yaw = math.atan2(r_wb[1, 0], r_wb[0, 0])
        r_h = yaw_matrix(-yaw) @ r_wb
        pitch = math.asin(max(-1.0, min(1.0, -r_h[2, 0])))
        roll = math.atan2(r_h[2, 1], r_h[2, 2])
        feet_h = (r_h @ silo6.leg_fk_body(geom, q).T).T
        return cls(touch, pos, roll, pitch, yaw, feet_h, last[SENSOR_SLICES["tips"]].reshape(6, 3))

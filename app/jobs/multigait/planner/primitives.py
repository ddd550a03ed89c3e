"""Gaits as motion primitives: batched simulation, planar displacement tables, composition.

On a flat map a gait moves the pivot by the same planar displacement (dx, dy, dyaw), in the
frame of the pivot at the gait's start, wherever the robot stands: MuJoCo's physics is
invariant to translations and to turns about the vertical. So each candidate's gaits are
simulated once from the rest pose at the origin, all candidates and gaits of a generation
in one native ``mujoco.rollout`` call, and the planner composes the cached displacement
(and the swept path, for collision checks and coverage) at every tree node.

What composition ignores: a real expansion starts from the joint angles and velocities the
parent gait left behind, not from the rest pose. Every gait therefore ends with a short
settle phase that brings the joints back to rest (``gait_setpoints``); the remaining error
is measured against full simulation (``verify_tree``) and reported with every run. On
the staircase expansions are simulated for real from the parent's full state.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
from mujoco import rollout

from app.jobs.multigait.cpg import gait_bounds, gait_setpoints
from app.jobs.multigait.planner.maps import PlanMap
from app.robots.modular import MU, PHYSICS, ModulePhysics, Shape, build_model, functional_modules
from app.sim.threads import sim_threads

_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def heading(quat: np.ndarray) -> np.ndarray:
    """Yaw of the body x axis projected on the floor (rad), for (..., 4) wxyz quaternions."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    return np.arctan2(2.0 * (x * y + w * z), 1.0 - 2.0 * (y * y + z * z))


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@dataclasses.dataclass
class Primitives:
    """Cached gait displacements of B candidates with k gaits each, in the start frame."""

    end_xy: np.ndarray  # (B, k, 2) mu
    dyaw: np.ndarray  # (B, k) rad
    path: np.ndarray  # (B, k, S, 3) pivot x, y, z (mu) at the samples, starting at (0, 0, z0)

    @property
    def k(self) -> int:
        return self.end_xy.shape[1]

    def distance(self) -> np.ndarray:
        return np.hypot(self.end_xy[..., 0], self.end_xy[..., 1])

    def take(self, idx) -> Primitives:
        return Primitives(self.end_xy[idx], self.dyaw[idx], self.path[idx])


class ModularSim:
    """One (damaged) modular robot on one map: CPG controls, batched rollouts, placement."""

    def __init__(self, shape: Shape, stuck: tuple[int, ...], pmap: PlanMap, gait_s: float, settle_s: float,
                 sample_s: float = 0.25, nthread: int | None = None, physics: ModulePhysics = PHYSICS):
        self.shape, self.stuck, self.pmap = shape, tuple(stuck), pmap
        self.spec, self.model = build_model(shape, self.stuck, pmap.terrain, physics)
        self.joints = functional_modules(shape, self.stuck)
        self.dt = self.model.opt.timestep
        self.n_gait = int(round(gait_s / self.dt))
        self.n_settle = int(round(settle_s / self.dt))
        self.nstep = self.n_gait + self.n_settle
        self.stride = max(1, int(round(sample_s / self.dt)))
        self.limit = float(self.model.jnt_range[self.model.actuator_trnid[0, 0], 1]) if self.model.nu else 0.0
        self.nthread = nthread or sim_threads()  # rollout results do not depend on it
        self._datas = [mujoco.MjData(self.model) for _ in range(self.nthread)]
        self._runner = rollout.Rollout(nthread=self.nthread)
        d = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, d)
        self.nstate = mujoco.mj_stateSize(self.model, _STATE)
        self.state0 = np.empty(self.nstate)
        mujoco.mj_getState(self.model, d, self.state0, _STATE)
        self.qoff = mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_TIME)
        self.voff = self.qoff + self.model.nq
        # pivot site in the root body's frame (the root body carries the free joint)
        self.pivot_local = self.model.site_pos[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, "pivot")].copy()
        self.sim_steps = 0

    @property
    def dim(self) -> int:
        return 6 * len(self.joints)

    def bounds(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = gait_bounds(len(self.joints))
        return np.tile(lo, k), np.tile(hi, k)

    # -- states -----------------------------------------------------------------------------
    def pivot_pose(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(..., nstate) -> pivot centre (..., 3) in mu and heading (...) in rad."""
        q = states[..., self.qoff : self.qoff + 7]
        pos, quat = q[..., :3], q[..., 3:7]
        w, x, y, z = np.moveaxis(quat, -1, 0)
        px, py, pz = self.pivot_local
        # R(quat) @ pivot_local
        rx = (1 - 2 * (y * y + z * z)) * px + 2 * (x * y - w * z) * py + 2 * (x * z + w * y) * pz
        ry = 2 * (x * y + w * z) * px + (1 - 2 * (x * x + z * z)) * py + 2 * (y * z - w * x) * pz
        rz = 2 * (x * z - w * y) * px + 2 * (y * z + w * x) * py + (1 - 2 * (x * x + y * y)) * pz
        return (pos + np.stack([rx, ry, rz], axis=-1)) / MU, heading(quat)

    def place(self, states: np.ndarray, x, y, yaw) -> np.ndarray:
        """Turn states about the world z axis by ``yaw`` and shift by (x, y) mu: a robot
        resting at the origin ends with its pivot at (x, y) heading ``yaw``."""
        s = np.array(states, dtype=float, copy=True)
        yaw = np.asarray(yaw, dtype=float)
        c, sn = np.cos(yaw), np.sin(yaw)
        q = s[..., self.qoff : self.qoff + 7]
        px, py = q[..., 0].copy(), q[..., 1].copy()
        q[..., 0] = c * px - sn * py + np.asarray(x) * MU
        q[..., 1] = sn * px + c * py + np.asarray(y) * MU
        qz = np.stack([np.cos(yaw / 2), np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2)], axis=-1)
        q[..., 3:7] = _qmul(np.broadcast_to(qz, q[..., 3:7].shape), q[..., 3:7])
        v = s[..., self.voff : self.voff + 3]
        vx, vy = v[..., 0].copy(), v[..., 1].copy()
        v[..., 0] = c * vx - sn * vy
        v[..., 1] = sn * vx + c * vy
        s[..., self.qoff : self.qoff + 7] = q
        s[..., self.voff : self.voff + 3] = v
        return s

    def start_state(self) -> np.ndarray:
        x, y, yaw = self.pmap.start
        return self.place(self.state0, x, y, yaw)

    # -- simulation ---------------------------------------------------------------------------
    def controls(self, gaits: np.ndarray) -> np.ndarray:
        """(G, 6 J) gait vectors -> (G, nstep, nu) PD setpoints."""
        return gait_setpoints(gaits, len(self.joints), self.n_gait, self.n_settle, self.dt, self.limit)

    def rollout(self, states: np.ndarray, ctrl: np.ndarray, full: bool = False):
        """Run G gaits from G states. Returns (pivot samples (G, S, 3) mu, headings (G, S),
        final states (G, nstate), and all states (G, nstep, nstate) if ``full``). The samples
        are the start and every ``stride`` steps after it, the last one being the end."""
        G = ctrl.shape[0]
        st, _ = self._runner.rollout(self.model, self._datas, np.ascontiguousarray(states), np.ascontiguousarray(ctrl))
        self.sim_steps += G * ctrl.shape[1]
        idx = self._sample_steps(ctrl.shape[1])
        samples = np.concatenate([states[:, None], st[:, idx]], axis=1)
        xyz, yaw = self.pivot_pose(samples)
        return xyz, np.unwrap(yaw, axis=1), st[:, -1].copy(), (st if full else None)

    def _sample_steps(self, nstep: int) -> np.ndarray:
        idx = np.arange(self.stride - 1, nstep, self.stride)
        if idx.size == 0 or idx[-1] != nstep - 1:
            idx = np.append(idx, nstep - 1)
        return idx

    @property
    def n_samples(self) -> int:
        """Pivot samples per gait (start included)."""
        return self._sample_steps(self.nstep).size + 1

    def primitives(self, gaits: np.ndarray, k: int) -> Primitives:
        """Simulate k gaits of each of B candidates ((B, k * 6 J) vectors) from rest at the
        origin, in one batched rollout, and cache their displacements."""
        g = np.atleast_2d(gaits)
        B = g.shape[0]
        flat = g.reshape(B * k, self.dim)
        xyz, yaw, _, _ = self.rollout(np.repeat(self.state0[None], B * k, axis=0), self.controls(flat))
        return self.to_primitives(xyz, yaw, B, k)

    @staticmethod
    def to_primitives(xyz: np.ndarray, yaw: np.ndarray, B: int, k: int) -> Primitives:
        p0, y0 = xyz[:, :1, :2], yaw[:, :1]
        c, s = np.cos(-y0), np.sin(-y0)
        dx, dy = xyz[..., 0] - p0[..., 0], xyz[..., 1] - p0[..., 1]
        local = np.stack([c * dx - s * dy, s * dx + c * dy, xyz[..., 2]], axis=-1)
        S = local.shape[1]
        path = local.reshape(B, k, S, 3)
        return Primitives(end_xy=path[:, :, -1, :2].copy(), dyaw=(yaw[:, -1] - yaw[:, 0]).reshape(B, k), path=path)

    def close(self) -> None:
        if self._runner is not None:
            self._runner.close()
            self._runner = None

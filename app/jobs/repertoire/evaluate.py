"""Batched scoring of repertoire gaits with native MuJoCo rollouts.

A batch of gaits is one ``mujoco.rollout`` call per chunk of the trial (a thread per
core, the datas and output buffers kept between calls); the set-points of the whole batch
for a chunk are one vectorised call of the controller; what a trial reports is reduced
from each chunk's sensor data as it comes (no per-step Python loop, no whole-trial arrays).

A trial: ``settle_s`` standing in the stance, then ``duration_s`` of the gait. Reported per
gait, over the gait's part of the trial (the robot's start frame: y forward, z up, taken
at the end of the settling):

- ``forward_m`` (the fitness): centre-of-mass displacement along the forward axis;
- ``lateral_m``: along the left axis (the drift);
- ``yaw_deg``: the heading's change;
- ``fell``: a body other than a foot touched the floor (the built-in's ``all_contacts``
  less its feet's counts; an uploaded robot's ``<body>_ground`` sensors) or the trunk tilted
  past MAX_TILT_DEG, at any step of the trial;
- ``energy_j``: the servos' mechanical work, sum over steps of |force x joint speed| x dt;
- ``contact``: per remaining leg, the share of steps its foot touches the floor;
- ``timestep_s``: the step the trial was simulated at.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from app.jobs.repertoire.body import STATE, Body
from app.jobs.repertoire.controller import Layout
from app.sim.batch import RolloutPool

MAX_TILT_DEG = 60.0
CHUNK_S = 0.5  # simulated time per rollout call: bounds the output buffers, not the numbers


def heading_axes(quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forward y axis, up z axis) in the world of frames with quaternions (..., 4) (w, x, y, z)."""
    w, x, y, z = (quat[..., i] for i in range(4))
    fwd = np.stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=-1)
    up = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)
    return fwd, up


def walk_metrics(com0: np.ndarray, quat0: np.ndarray, com1: np.ndarray, quat1: np.ndarray) -> dict[str, np.ndarray]:
    """forward_m, lateral_m, yaw_deg from the start and end centre of mass (P, 3) and trunk
    quaternions (P, 4): the start frame's forward axis flattened onto the floor."""
    f0 = heading_axes(quat0)[0][:, :2]
    f0 = f0 / np.maximum(np.linalg.norm(f0, axis=-1, keepdims=True), 1e-12)
    left = np.stack([-f0[:, 1], f0[:, 0]], axis=-1)
    d = (com1 - com0)[:, :2]
    f1 = heading_axes(quat1)[0][:, :2]
    yaw = np.degrees(np.arctan2(f0[:, 0] * f1[:, 1] - f0[:, 1] * f1[:, 0], np.sum(f0 * f1, axis=-1)))
    return {"forward_m": np.sum(d * f0, axis=-1), "lateral_m": np.sum(d * left, axis=-1), "yaw_deg": yaw}


class Evaluator:
    """Scores gaits (P, layout.dim) of one robot at its model's timestep."""

    def __init__(self, body: Body, layout: Layout, duration_s: float, settle_s: float, nthread: int | None = None):
        self.body, self.layout, self.model = body, layout, body.model
        m = self.model
        self.dt = float(m.opt.timestep)
        self.n_settle = int(round(settle_s / self.dt))
        self.n_walk = max(1, int(round(duration_s / self.dt)))
        self.nstep = self.n_settle + self.n_walk
        self._pool = RolloutPool(m, nthread)
        self.nthread = self._pool.nthread
        self._nstate = mujoco.mj_stateSize(m, STATE)
        sens = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SENSOR, i): (int(m.sensor_adr[i]), int(m.sensor_dim[i]))
                for i in range(m.nsensor)}
        self._sens = sens
        self._feet = np.array([sens[f][0] for f in body.feet], dtype=int)
        self._all = sens["all_contacts"][0] if "all_contacts" in sens else None
        self._ground = np.array([a for n, (a, _) in sens.items() if n.endswith("_ground")], dtype=int)
        self._force = np.array([sens[f"rep_force_{k}"][0] for k in range(m.nu)], dtype=int)
        self._speed = np.array([sens[f"rep_speed_{k}"][0] for k in range(m.nu)], dtype=int)
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, body.state0, STATE)
        mujoco.mj_forward(m, d)
        self._sensor0 = d.sensordata.copy()  # what the sensors read in the first state
        self._min_up = math.cos(math.radians(MAX_TILT_DEG))
        self._settled: tuple[np.ndarray, bool, np.ndarray] | None = None

    # -- pieces ---------------------------------------------------------------------------
    def chunks(self) -> list[tuple[int, int]]:
        """Step ranges of the rollout calls; the settling ends at a boundary."""
        n = max(1, int(round(CHUNK_S / self.dt)))
        stops = sorted({*range(n, self.nstep, n), self.n_settle, self.nstep} - {0})
        return list(zip([0, *stops[:-1]], stops))

    def controls(self, x: np.ndarray, start: int, stop: int) -> np.ndarray:
        """Set-points (P, stop - start, nu) of gaits x for steps [start, stop)."""
        t = (np.arange(start, stop) - self.n_settle) * self.dt
        return self.layout.setpoints(x, t)

    def _sensor(self, sens: np.ndarray, name: str) -> np.ndarray:
        adr, dim = self._sens[name]
        return sens[..., adr:adr + dim]

    def ground_contacts(self, sens: np.ndarray) -> np.ndarray:
        """(...,) contacts of bodies that must not touch the floor."""
        if self._all is not None:
            return sens[..., self._all] - sens[..., self._feet].sum(axis=-1)
        if self._ground.size:
            return sens[..., self._ground].sum(axis=-1)
        return np.zeros(sens.shape[:-1])

    def _rollout(self, state: np.ndarray, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._pool.run(self.model, state, ctrl, self._nstate, self.model.nsensordata)

    def settled(self) -> tuple[np.ndarray, bool, np.ndarray]:
        """(state, fell, sensor data) at the end of the settling, which every gait shares
        (its set-points are the stance whatever the gait): simulated once per evaluator, in
        the same chunks as a trial, so a gait's numbers are those of simulating its whole
        trial (tests/jobs/repertoire compare with a per-step reference). A trial spends
        ``settle_s`` of its ``settle_s + duration_s`` there (1/7 of the default's steps)."""
        if self._settled is None:
            state, fell, sens = self.body.state0[None].copy(), False, self._sensor0[None]
            x = np.full((1, self.layout.dim), 0.5)  # any gait: the settling's set-points are the stance
            for start, stop in self.chunks():
                if stop > self.n_settle:
                    break
                st, sd = self._rollout(state, self.controls(x, start, stop))
                state = st[:, -1].copy()
                quat = self._sensor(sd, "torso_quat")
                up = 1 - 2 * (quat[..., 1] ** 2 + quat[..., 2] ** 2)
                fell |= bool(np.any((self.ground_contacts(sd) > 0) | (up < self._min_up)))
                sens = sd[:, -1].copy()
            self._settled = (state[0], fell, sens[0])
        return self._settled

    # -- scoring --------------------------------------------------------------------------
    def evaluate(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Metrics of gaits x (P, dim) (module doc): arrays with a leading axis P."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        P = x.shape[0]
        L = self._feet.size
        touch = np.zeros((P, L))
        energy = np.zeros(P)
        settled, settle_fell, settle_sens = self.settled()
        state = np.repeat(settled[None], P, axis=0)
        fell = np.full(P, settle_fell)
        start_sens = np.repeat(settle_sens[None], P, axis=0)
        last = start_sens
        for start, stop in self.chunks():
            if stop <= self.n_settle:  # the settling: the same for every gait, simulated once
                continue
            st, sd = self._rollout(state, self.controls(x, start, stop))
            state = st[:, -1].copy()
            quat = self._sensor(sd, "torso_quat")
            up = 1 - 2 * (quat[..., 1] ** 2 + quat[..., 2] ** 2)
            fell |= np.any((self.ground_contacts(sd) > 0) | (up < self._min_up), axis=1)
            touch += np.sum(sd[..., self._feet] > 0, axis=1)
            power = np.abs(sd[..., self._force] * sd[..., self._speed]).sum(axis=-1)
            energy += power.sum(axis=1) * self.dt
            last = sd[:, -1]
        m = walk_metrics(self._sensor(start_sens, "com_pos"), self._sensor(start_sens, "torso_quat"),
                         self._sensor(last, "com_pos"), self._sensor(last, "torso_quat"))
        m.update(fell=fell, energy_j=energy, contact=touch / self.n_walk, timestep_s=np.full(P, self.dt))
        return m

    def record(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The per-step record of one gait (the bundle's trace and the replay): one rollout
        call over the whole trial."""
        x = np.asarray(x, dtype=float).reshape(1, -1)
        ctrl = self.controls(x, 0, self.nstep)
        st, sd = self._rollout(self.body.state0[None].copy(), ctrl)
        st, sd = st[0].copy(), sd[0].copy()
        nq = self.model.nq
        off = mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_TIME)
        quat = self._sensor(sd, "torso_quat")
        fwd, up = heading_axes(quat)
        return {"time_s": (np.arange(self.nstep) + 1 - self.n_settle) * self.dt,
                "qpos": st[:, off:off + nq], "ctrl": ctrl[0],
                "com_m": self._sensor(sd, "com_pos"), "torso_quat": quat,
                "heading_deg": np.degrees(np.unwrap(np.arctan2(-fwd[:, 0], fwd[:, 1]))),
                "tilt_deg": np.degrees(np.arccos(np.clip(up[:, 2], -1.0, 1.0))),
                "foot_contact": sd[:, self._feet] > 0}

    def close(self) -> None:
        self._pool.close()


def descriptors(metrics: dict[str, np.ndarray], descriptor) -> np.ndarray:
    """The behaviour descriptor (P, D) of scored gaits (spec.descriptor, app/jobs/repertoire/spec.py)."""
    if descriptor.type == "contact_share":
        return np.asarray(metrics["contact"], dtype=float)
    lo = np.array([descriptor.forward_m[0], descriptor.lateral_m[0]])
    hi = np.array([descriptor.forward_m[1], descriptor.lateral_m[1]])
    return np.clip(np.stack([metrics["forward_m"], metrics["lateral_m"]], axis=-1), lo, hi)


def slices(n: int) -> list[tuple[int, int]]:
    """The 2-D slices a map of n descriptor dimensions is drawn in: consecutive pairs
    (left and right leg of a rank, for the contact share), the last with the first when n
    is odd; one axis alone when n is 1."""
    if n <= 1:
        return [(0, 0)]
    pairs = [(i, i + 1) for i in range(0, n - 1, 2)]
    if n % 2:
        pairs.append((n - 1, 0))
    return pairs


def descriptor_ranges(descriptor, legs: list[str]) -> tuple[list[str], list[tuple[float, float]]]:
    """(names, bounds) of the descriptor's dimensions."""
    if descriptor.type == "contact_share":
        return [f"contact_{l}" for l in legs], [(0.0, 1.0)] * len(legs)
    return ["forward_m", "lateral_m"], [tuple(descriptor.forward_m), tuple(descriptor.lateral_m)]

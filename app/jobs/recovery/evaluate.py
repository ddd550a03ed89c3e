"""Batched evaluation of leg-tip gait candidates with native MuJoCo rollouts.

A whole population is one ``mujoco.rollout`` call per chunk, a thread per core. Controls
(PID position setpoints) for all candidates are computed at once: one gait period of tip
targets (Eq. 3) and their IK, tiled over the run. The run is cut into chunks; after each
chunk the candidates that fell are dropped, so a fallen candidate stops costing
simulation time, and the survivors continue from their exact state.

With ``variants`` (models of the same size signature and timestep, e.g. perturbed
friction or masses), every candidate runs on each of them in the same rollout call, one
model per batch element: ``evaluate_all`` returns metrics of shape (P, K).

With ``SimConfig.law`` (the spec's ``control.mode: closed_loop``), the set-points are not
one period tiled: the chunks end at the correction's update ticks, and before each chunk
``closedloop.ChunkController`` reads the chassis' orientation (and position) of every walk
still going and computes its set-points for the chunk (app/jobs/recovery/gait_controller.py).

Fall test: the robot has fallen when its chassis, a coxa or a femur touches the ground
(MuJoCo contact sensors: every contact less the feet's, see
``app.robots.hexapod.add_fall_sensors``; an uploaded robot's ``*_ground``), or
when the body tilts past ``max_tilt_deg`` or sags below half its standing height.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.ik import leg_ik
from app.jobs.recovery.closedloop import ChunkController, Law
from app.jobs.recovery.sequences import GaitSequence
from app.jobs.recovery.trajectory import tip_positions, tip_shapes
from app.robots.catalog import RobotEntry
from app.robots.hexapod import ALL_CONTACTS, JOINT_NAMES
from app.jobs.recovery.metrics import body_metrics, euler_zyx, fallen, fitness_bound
from app.sim.perturb import same_signature
from app.sim.batch import RolloutPool

_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclasses.dataclass(frozen=True)
class SimConfig:
    duration_s: float = 10.0
    settle_s: float = 0.5  # the robot stands on its first pose before the gait starts
    chunk_s: float = 1.0
    period_s: float = 0.6
    stance_height_m: float = 0.10
    step_depth_m: float = 0.0
    max_tilt_deg: float = 60.0
    nthread: int | None = None
    law: Law | None = None  # the closed-loop correction; None: open loop (the paper)


@dataclasses.dataclass
class EvalResult:
    metrics: dict[str, np.ndarray]
    sim_steps: int  # steps actually simulated (fallen candidates stop early)


# The speed cap of a cut walk: this many times the gait's nominal speed (step length per
# gait period, what a foot that does not slip gives the body). On uniform random walks of
# the four Table II damages the fastest mean speed over the rest of a walk stayed near twice
# the nominal speed (docs/recovery_speed.md, "speed cap"); three times leaves a margin, and
# every documented answer searched again with cut walks came out the same (same page).
CUT_SPEED_FACTOR = 3.0


@dataclasses.dataclass
class Cutoff:
    """Early termination of the walks that can no longer win their selection (DE's
    one-to-one selection, Eq. 10: a trial replaces its parent only if its F is at least the
    parent's). After each chunk, a walk's Eq. 5 fitness is bounded from above by
    ``fitness_bound``: the roll and pitch amplitudes so far (they can only grow), no drift
    and no yaw, and the forward displacement so far plus ``speed_cap_m_s`` times the time
    left. A walk whose bound is below its threshold stops there; its fitness is reported
    as the bound, which is below the parent's, so the selection is the one the whole walk
    would have made whenever the cap holds (the rule and its check: docs/recovery_speed.md).
    """

    thresholds: np.ndarray  # (P,) the F each candidate must reach (DE: its parent's)
    speed_cap_m_s: np.ndarray  # (P,) bound on the mean forward speed over the rest of a walk
    weights: tuple[float, ...]
    units: str
    saved_steps: int = 0  # the steps the cut walks would still have taken
    cut: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=bool))
    bound: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    _lo: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    _hi: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))

    def start(self, P: int) -> None:
        self.cut, self.bound, self.saved_steps = np.zeros(P, dtype=bool), np.full(P, np.inf), 0
        self._lo, self._hi = np.full((P, 2), np.inf), np.full((P, 2), -np.inf)

    def update(self, ev: "GaitEvaluator", alive: np.ndarray, sens: np.ndarray, start: int, stop: int) -> np.ndarray:
        """(len(alive),) True for the walks to cut after the chunk [start, stop)."""
        first = ev.n_settle - 1  # the walking window's first step (as in evaluate_all)
        if stop <= first + 1:
            return np.zeros(alive.size, dtype=bool)
        seg = sens[alive, max(start, first):stop]
        ang = np.degrees(euler_zyx(ev._sensor(seg, "torso_quat"))[..., 1:])  # (A, T, [about y, about x])
        self._lo[alive] = np.minimum(self._lo[alive], ang.min(axis=1))
        self._hi[alive] = np.maximum(self._hi[alive], ang.max(axis=1))
        amp = 0.5 * (self._hi[alive] - self._lo[alive])
        y = ev._sens["com_pos"][0] + 1
        reach = sens[alive, stop - 1, y] - sens[alive, first, y] + self.speed_cap_m_s[alive] * (ev.nstep - stop) * ev.dt
        b = fitness_bound(reach, amp[:, 0], amp[:, 1], self.weights, self.units)
        out = b < self.thresholds[alive]
        self.cut[alive[out]] = True
        self.bound[alive[out]] = b[out]
        self.saved_steps += int(np.sum(out)) * (ev.nstep - stop)
        return out


class GaitEvaluator:
    """Evaluates tip-trajectory parameter vectors for one (damaged) robot and sequence."""

    def __init__(self, robot: RobotEntry, model: mujoco.MjModel, seq: GaitSequence, cfg: SimConfig,
                 variants: list[mujoco.MjModel] | None = None):
        self.robot, self.model, self.seq, self.cfg = robot, model, seq, cfg
        self.variants = list(variants) if variants else [model]
        for v in self.variants:
            if not same_signature(v, model):
                raise ValueError("variants must share the model's sizes and timestep (one rollout call)")
        self.legs = seq.legs
        self.dt = model.opt.timestep
        self.n_settle = int(round(cfg.settle_s / self.dt))
        self.n_walk = int(round(cfg.duration_s / self.dt))
        self.n_period = int(round(cfg.period_s / self.dt))
        self.nstep = self.n_settle + self.n_walk
        self._pool = RolloutPool(model, cfg.nthread)
        self.nthread = self._pool.nthread

        self.root_quat = (1.0, 0.0, 0.0, 0.0)  # the trunk's orientation in every walk's first state
        self._leg_layout(robot, model, cfg)
        # qpos address of each actuated joint, to start every candidate in its first pose.
        self.qpos_adr = np.array([model.jnt_qposadr[model.actuator_trnid[a, 0]] for a in range(model.nu)])
        d = mujoco.MjData(model)
        self._nstate = mujoco.mj_stateSize(model, _STATE)
        self._state0 = np.empty(self._nstate)
        mujoco.mj_getState(model, d, self._state0, _STATE)
        self._qpos_off = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)
        self._sens = {n: (model.sensor_adr[i], model.sensor_dim[i])
                      for i in range(model.nsensor)
                      for n in [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i)]}
        self._ground = np.array([model.sensor_adr[i] for i in range(model.nsensor)
                                 if model.sensor_type[i] == mujoco.mjtSensor.mjSENS_CONTACT
                                 and mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i).endswith("_ground")],
                                dtype=int)
        self._feet = np.array([model.sensor_adr[i] for i in range(model.nsensor)
                               if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i).endswith("_foot_touch")],
                              dtype=int)
        self._all = self._sens[ALL_CONTACTS][0] if ALL_CONTACTS in self._sens else None

    def _leg_layout(self, robot: RobotEntry, model: mujoco.MjModel, cfg: SimConfig) -> None:
        """The legs' side signs, the ctrl column of each (leg, joint), the standing and the
        fall heights. An uploaded robot (``robot.gait_layout``, app/jobs/recovery/userrobot.py)
        sets these, its first orientation and its own ``joint_targets`` (numerical IK)."""
        custom = getattr(robot, "gait_layout", None)
        if custom is not None:
            custom(self, model, cfg)
            return
        geom = robot.geometry
        self.sides = np.array([geom.leg(l).side for l in self.legs])
        # ctrl column of each (leg, joint), or -1 for a joint without an actuator (locked).
        cols = np.full((len(self.legs), 3), -1)
        for a in range(model.nu):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
            leg_s, joint_s, _ = name.split("_")
            leg = int(leg_s[3:])
            if leg in self.legs:
                cols[self.legs.index(leg), JOINT_NAMES.index(joint_s)] = a
        self.ctrl_cols = cols
        self.torso_height0 = cfg.stance_height_m + geom.foot_radius + 0.002
        self.min_height = 0.5 * (cfg.stance_height_m + geom.foot_radius)

    # -- controls ---------------------------------------------------------------------
    def period_tips(self, params: np.ndarray) -> np.ndarray:
        """Tip targets (P, n_period, nlegs, 3) over one gait period, in the hip frames."""
        t = np.arange(self.n_period) * self.dt
        return tip_positions(params, self.legs, self.seq, t, self.n_period * self.dt,
                             self.cfg.stance_height_m, self.cfg.step_depth_m)

    def balance_levers(self) -> np.ndarray:
        """Each leg's foot at the nominal stance (nlegs, 2): (right, forward) in metres in the
        trunk's frame, where the balance correction reads the trunk's tilt."""
        feet = self.robot.nominal_feet_xy()
        return np.array([feet[l] for l in self.legs], dtype=float)

    def stride_shape(self) -> np.ndarray:
        """Eq. 3's stride shape y_rel (n_period, nlegs) in [-1, 1] (closed loop scales it)."""
        t = np.arange(self.n_period) * self.dt
        return tip_shapes(t, self.n_period * self.dt, self.seq, self.legs)[0]

    def joint_targets(self, params: np.ndarray) -> np.ndarray:
        """Joint setpoints (P, n_period, nlegs, 3) over one gait period."""
        tips = self.period_tips(params)
        tips[..., 1] *= self.sides  # hip frame (y forward) -> leg frame (left legs turned 180 deg)
        return leg_ik(tips, self.robot.geometry.link_lengths)

    def period_controls(self, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One gait period of setpoints (P, n_period, nu) and the initial states (P, nstate)."""
        q = self.joint_targets(params)
        P = q.shape[0]
        period = np.empty((P, self.n_period, self.model.nu))
        mask = self.ctrl_cols >= 0
        period[:, :, self.ctrl_cols[mask]] = q[:, :, mask]
        state = np.repeat(self._state0[None], P, axis=0)
        qpos = state[:, self._qpos_off : self._qpos_off + self.model.nq]
        qpos[:, 0:3] = (0.0, 0.0, self.torso_height0)
        qpos[:, 3:7] = self.root_quat
        qpos[:, self.qpos_adr] = period[:, 0]
        return period, state

    def control_steps(self, start: int, stop: int) -> np.ndarray:
        """Which step of the period each step in [start, stop) holds: the first pose while
        the robot settles, then the period over and over."""
        k = np.arange(start, stop)
        return np.where(k < self.n_settle, 0, (k - self.n_settle) % self.n_period)

    def controls(self, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Control sequences (P, nstep, nu) and initial states (P, nstate)."""
        period, state = self.period_controls(params)
        return period[:, self.control_steps(0, self.nstep)], state

    # -- simulation ---------------------------------------------------------------------
    def _rollout(self, models, state: np.ndarray, ctrl: np.ndarray):
        """One native rollout call (app/sim/batch.py)."""
        m = models[0] if len(self.variants) == 1 else models
        return self._pool.run(m, state, ctrl, self._nstate, self.model.nsensordata)

    def simulate(self, params: np.ndarray, record: bool = False, cutoff: Cutoff | None = None):
        """Runs every candidate on every variant (batch element b = candidate b // K on
        variant b % K); returns (sensordata (B, T, ns), alive-until step (B,), states
        (B, T, nstate) if record else None, steps simulated). With ``cutoff`` (one model),
        a walk also ends at the chunk after which its fitness can no longer reach its
        threshold: ``cutoff.cut`` and ``cutoff.bound`` then say which and the bound.
        With ``record``, ``self.recorded`` holds the set-points applied (B, T, nu) and, in
        closed loop, the last command of each walk."""
        params = np.atleast_2d(params)
        period, state = self.period_controls(params)
        K = len(self.variants)
        if K > 1:
            period, state = np.repeat(period, K, axis=0), np.repeat(state, K, axis=0)
        P = period.shape[0]
        models = np.empty(P, dtype=object)
        models[:] = self.variants * (P // K)
        sens = np.zeros((P, self.nstep, self.model.nsensordata))
        states = np.zeros((P, self.nstep, self._nstate)) if record else None
        ctrls = np.zeros((P, self.nstep, self.model.nu)) if record else None
        end = np.full(P, self.nstep)
        alive = np.arange(P)
        loop = None if self.cfg.law is None else ChunkController(self, np.repeat(params, K, axis=0), self.cfg.law,
                                                                 period)
        chunk = max(1, int(round(self.cfg.chunk_s / self.dt)))
        stops = loop.boundaries() if loop is not None else list(range(chunk, self.nstep, chunk)) + [self.nstep]
        steps = 0
        for start, stop in zip([0] + stops[:-1], stops):
            if alive.size == 0:
                break
            if loop is None:
                ctrl = period[alive][:, self.control_steps(start, stop)]
            else:
                ctrl = loop.ctrl(alive, start, stop, state)
            st, sd = self._rollout(list(models[alive]), state[alive], ctrl)
            rows = slice(None) if alive.size == P else alive  # a plain slice copies 4x faster than an index array
            sens[rows, start:stop] = sd
            if record:
                states[rows, start:stop] = st
                ctrls[rows, start:stop] = ctrl
            steps += alive.size * (stop - start)
            state[alive] = st[:, -1]
            done = self._fell(sd)
            if cutoff is not None and stop < self.nstep:
                done |= cutoff.update(self, alive, sens, start, stop) & ~done
            end[alive[done]] = stop
            alive = alive[~done]
        if record:
            self.recorded = {"ctrl": ctrls, "commands": None if loop is None else loop.commands()}
        return sens, end, states, steps

    def _sensor(self, sens: np.ndarray, name: str) -> np.ndarray:
        adr, dim = self._sens[name]
        return sens[..., adr : adr + dim]

    def ground_contacts(self, sens: np.ndarray) -> np.ndarray | None:
        """(..., n) contact counts of the bodies that must never touch the ground, from
        sensordata (..., nsensordata): the built-in robots' every contact less the feet's
        (``app.robots.hexapod.add_fall_sensors``), an uploaded robot's sensor per body
        (``<body>_ground``); None without either."""
        if self._all is not None:
            return (sens[..., self._all] - sens[..., self._feet].sum(axis=-1))[..., None]
        return sens[..., self._ground] if self._ground.size else None

    def _fell(self, sens: np.ndarray) -> np.ndarray:
        pos = self._sensor(sens, "torso_pos")
        return fallen(pos[..., 2], self._sensor(sens, "torso_quat"), self.min_height,
                      math.radians(self.cfg.max_tilt_deg), self.ground_contacts(sens))

    def evaluate_all(self, params: np.ndarray, cutoff: Cutoff | None = None) -> EvalResult:
        """Metrics of shape (P, K): every candidate on every variant. With ``cutoff`` (a
        single model), the walks it cut short are marked in ``cutoff.cut``: their metrics
        are of a partial walk and only ``cutoff.bound`` says anything about them."""
        params = np.atleast_2d(params)
        if cutoff is not None:
            if len(self.variants) != 1:
                raise ValueError("walks are cut short on a single model only")
            cutoff.start(params.shape[0])
        sens, end, _, steps = self.simulate(params, cutoff=cutoff)
        fell = end < self.nstep
        if cutoff is not None:
            fell &= ~cutoff.cut
        walk = sens[:, self.n_settle - 1 :]
        feet = walk[..., self._feet] if self._feet.size else None
        m = body_metrics(self._sensor(walk, "com_pos"), self._sensor(walk, "torso_quat"), fell, feet)
        K = len(self.variants)
        return EvalResult(metrics={k: v.reshape(-1, K) for k, v in m.items()}, sim_steps=steps)

    def evaluate(self, params: np.ndarray, cutoff: Cutoff | None = None) -> EvalResult:
        """Metrics of shape (P,) on the single model."""
        if len(self.variants) != 1:
            raise ValueError("this evaluator has several variants: use evaluate_all")
        r = self.evaluate_all(params, cutoff)
        return EvalResult(metrics={k: v[:, 0] for k, v in r.metrics.items()}, sim_steps=r.sim_steps)

    def trace(self, params: np.ndarray) -> dict[str, np.ndarray]:
        """Per-step record of one candidate (on the first variant) for plots, bundles and replay."""
        if len(self.variants) != 1:
            raise ValueError("trace runs on a single model")
        params = np.atleast_2d(params)[:1]
        sens, end, states, _ = self.simulate(params, record=True)
        m = self.model
        n = int(end[0])
        qpos = states[0, :n, self._qpos_off : self._qpos_off + m.nq]
        quat = self._sensor(sens[0, :n], "torso_quat")
        ang = np.degrees(euler_zyx(quat))
        d = mujoco.MjData(m)
        foot_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"leg{l}_tip") for l in self.legs]
        feet = np.empty((n, len(self.legs), 3))
        for i in range(n):  # kinematics only, for one recorded trajectory (not a search path)
            d.qpos[:] = qpos[i]
            mujoco.mj_kinematics(m, d)
            feet[i] = d.site_xpos[foot_ids]
        contact = feet[..., 2] < self.robot.geometry.foot_radius + 0.003
        t = np.arange(n) * self.dt - self.cfg.settle_s + self.dt
        return {
            "time_s": t,
            "com_m": self._sensor(sens[0, :n], "com_pos"),
            "torso_pos_m": self._sensor(sens[0, :n], "torso_pos"),
            "torso_quat": quat,
            "yaw_deg": np.degrees(np.unwrap(np.radians(ang[:, 0]))),
            "roll_deg": ang[:, 1],
            "pitch_deg": ang[:, 2],
            "qpos": qpos,
            "ctrl": self.recorded["ctrl"][0, :n],  # the servo set-points applied (rad), in actuator order
            "feet_m": feet,
            "foot_contact": contact,
            "legs": np.array(self.legs),
        }

    def close(self) -> None:
        self._pool.close()

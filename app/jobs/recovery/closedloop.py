"""The closed-loop heading and drift correction as the recovery simulation runs it.

The law itself is ``gait_controller.py`` (numpy only: the module a bundle ships and a robot
runs); this module turns a spec into its settings (``Law``) and gives the batched evaluator
a controller over a population, fed in the rollout's chunk loop with what a robot senses:

- heading: the torso's orientation (its free joint's quaternion: the attitude an IMU fixed
  to the chassis reports);
- drift (with ``odometry``): the torso's position in the plane (its free joint's position:
  what leg, visual or motion-capture odometry gives a robot), across the heading the walk
  started with.

Both are read once per update (every gait period, or every phase: a period over the
sequence's sigma phases), from the state the rollout reached at the update tick. (Not from
the ``torso_quat`` / ``torso_pos`` sensors: those follow the torso's inertial frame, which a
payload shifts and turns; an IMU is bolted to the chassis.)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.recovery.gait_controller import GAINS, LIMITS, GaitController

UPDATES = ("period", "phase")


@dataclasses.dataclass(frozen=True)
class Law:
    """The correction's settings: gains (``gait_controller.GAINS``), limits, how often it is
    updated, whether it uses odometry, and the gait's stride bounds (the search's)."""

    yaw_gain: float
    yaw_integral_gain: float
    lateral_gain: float
    lateral_integral_gain: float
    stride_limit_m: float
    lateral_limit_m: float
    balance_gain: float = 0.0
    balance_integral_gain: float = 0.0
    balance_limit_m: float = 0.0
    update: str = "period"
    odometry: bool = True
    stride_bounds: tuple[float, float] = (0.0, 1.0)

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in GAINS + LIMITS} | {"odometry": self.odometry, "update": self.update}

    def update_steps(self, n_period: int, sigma: int) -> int:
        return n_period if self.update == "period" else max(1, int(round(n_period / sigma)))


METRE_VALUED = ("yaw_gain", "yaw_integral_gain", "stride_limit_m", "lateral_limit_m", "balance_limit_m")  # m/rad, m


def law_of(control, stride_bounds: tuple[float, float], scale: float = 1.0) -> Law | None:
    """The spec's ``control`` section as a Law (None: open loop, the paper). ``scale``
    multiplies the metre-valued gains and limits (the spec's are the JetHexa's: an uploaded
    robot's are scaled by its stance height over the JetHexa's, as its search bounds are);
    the lateral and balance gains are metres per metre and stay."""
    if control.mode != "closed_loop":
        return None
    values = {k: getattr(control, k) * (scale if k in METRE_VALUED else 1.0) for k in GAINS + LIMITS}
    return Law(**values, update=control.update, odometry=control.odometry,
               stride_bounds=(float(stride_bounds[0]), float(stride_bounds[1])))


class ChunkController:
    """The controller of a whole rollout batch (every candidate on every variant) inside the
    evaluator's chunk loop: ``ctrl(rows, start, stop, state)`` gives the set-points (A, T, nu)
    of the rows still walking for the chunk [start, stop) of the rollout, after updating
    the correction from their state at ``start`` (``state``: (B, nstate), full physics)."""

    def __init__(self, ev, params: np.ndarray, law: Law, period: np.ndarray):
        n = len(ev.legs)
        chain = getattr(ev, "controller_chain", None)  # an uploaded robot: its numerical IK (userrobot.py)
        self.ev, self.period = ev, period
        self.update_steps = law.update_steps(ev.n_period, ev.seq.sigma)
        self.ctl = GaitController(ev.period_tips(params), ev.stride_shape(), params[:, 2 * n], ev.sides,
                                  () if chain else ev.robot.geometry.link_lengths, law.stride_bounds,
                                  self.update_steps, law.as_dict(), batch=params.shape[0], chain=chain,
                                  heading=getattr(ev, "controller_heading", None), levers=ev.balance_levers())
        self.mask = ev.ctrl_cols >= 0
        self.root = ev._qpos_off  # the free joint's qpos (x, y, z, qw, qx, qy, qz) in the state

    def boundaries(self) -> list[int]:
        """The rollout's chunk ends: the settling, then every update tick to the end."""
        ev = self.ev
        if ev.n_settle < 1:
            raise ValueError("closed loop needs a settling time (sim.settle_s > 0): the walk's start is a reading")
        return [ev.n_settle] + list(range(ev.n_settle + self.update_steps, ev.nstep, self.update_steps)) + [ev.nstep]

    def ctrl(self, rows: np.ndarray, start: int, stop: int, state: np.ndarray) -> np.ndarray:
        ev = self.ev
        if stop <= ev.n_settle:  # standing on the first pose
            return self.period[rows][:, ev.control_steps(start, stop)]
        j0, j1 = start - ev.n_settle, stop - ev.n_settle
        pos, quat = self.reading(state[rows])
        if j0 == 0:
            self.ctl.start(quat, pos, rows)
        else:
            self.ctl.update(quat, pos, rows)
        q = self.ctl.joint_angles(j0, j1, rows)
        out = np.empty((rows.size, stop - start, ev.model.nu))
        out[:, :, ev.ctrl_cols[self.mask]] = q[:, :, self.mask]
        return out

    def reading(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(position (A, 3), orientation (A, 4) w, x, y, z) of the chassis in states (A, nstate)."""
        return state[:, self.root: self.root + 3], state[:, self.root + 3: self.root + 7]

    def commands(self) -> np.ndarray:
        """The last command of every row ([stride difference m, crab stride m])."""
        return self.ctl.cmd.copy()

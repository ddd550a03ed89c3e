"""The set-points of a recovered gait, with its closed-loop heading and drift correction.

This file is the controller a gaitmend recovery bundle ships (``controller/gait_controller.py``)
and the very module gaitmend's simulation runs (app/jobs/recovery/closedloop.py): it imports
numpy and nothing else, so it runs on a robot without gaitmend. ``gait.json`` beside it in
the bundle holds the gait (``GaitController.from_json``).

What it computes, per servo tick ``j`` of the walk (``j = 0`` when the walk starts, after the
robot stood ``settle_steps`` ticks on the gait's first pose):

- the open-loop tip targets of the gait (paper 000, Eq. 3), one period of them stored in
  ``base_tips`` (hip frame: x outward, y forward, z up) and repeated;
- the correction, updated every ``update_steps`` ticks (once per gait period or per phase)
  from the IMU's body orientation and, with ``odometry``, the body's position:
  * heading: yaw error e (rad) from the yaw at the walk's start -> stride difference
    d = clip(yaw_gain e + yaw_integral_gain sum(e), +-stride_limit_m); each leg's stride is
    clip(L - side d, stride_bounds widened to hold L) (side -1 left, +1 right), so a robot turned left
    (e > 0) takes longer strides on its left and turns back right;
  * drift: lateral offset s (m) from the start, across the start heading -> a crab stride
    c = -clip(lateral_gain s + lateral_integral_gain sum(s), +-lateral_limit_m): every foot
    moves c/2 -> -c/2 sideways over its support (as the stride moves it forward to back),
    which carries the body c per period back toward its line;
  * balance (where its gains are not 0): the torso's tilt from the IMU, as the height of the
    trunk over each foot relative to level, h_i = R_zx x_i + R_zy y_i (R the gait frame's
    orientation, (x_i, y_i) the foot's nominal place about the feet's centroid, x right, y
    forward) -> each tip's height offset dz_i = clip(balance_gain h_i + balance_integral_gain
    sum(h_i), +-balance_limit_m): a leg under a low side of the trunk reaches further down
    and lifts it, the one under a high side draws up (the offsets sum to 0: the trunk's mean
    height stays);
  * the integrals stop growing where their term alone reaches the limit (anti-windup);
  * a new command is ramped in linearly over the next ``update_steps`` ticks, so the
    set-points never jump;
- each tip through the closed-form leg IK (Eq. 11) -> coxa, femur, tibia angles in
  radians, from the model's zero pose. The IK is the robot layer's (app/robots/ik.py, numpy
  only): the bundle ships that file as ``controller/ik.py`` beside this one, and this module
  imports it from there when it runs outside gaitmend, so the robot runs the IK the
  simulation ran, from one source;
- or, for a robot of any leg layout (an uploaded robot: ``chain``), each tip from its hip
  frame into the trunk's frame (the frame's origin, outward, forward and up axes) and
  through the numerical leg IK (app/robots/chain_ik.py, numpy only, the chains as data):
  every leg joint's qpos, legs in order, joints from the trunk out.

Everything is batched over ``batch`` robots (the simulation runs a whole population at
once); on a robot, ``batch`` is 1.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

if __package__ and __package__.split(".")[0] == "app":  # inside gaitmend
    from app.robots.chain_ik import ChainIK
    from app.robots.ik import leg_ik
else:  # on the robot: the bundle's controller/ik.py and chain_ik.py, the same files
    from chain_ik import ChainIK  # type: ignore[no-redef]
    from ik import leg_ik  # type: ignore[no-redef]

__all__ = ["GAINS", "LIMITS", "GaitController", "leg_ik", "trunk_targets", "walk", "yaw_of"]

GAINS = ("yaw_gain", "yaw_integral_gain", "lateral_gain", "lateral_integral_gain", "balance_gain",
         "balance_integral_gain")
LIMITS = ("stride_limit_m", "lateral_limit_m", "balance_limit_m")
BALANCE = ("balance_gain", "balance_integral_gain", "balance_limit_m")  # absent from gait.json before balance: 0


def yaw_of(quat: np.ndarray) -> np.ndarray:
    """Heading (rad) about the world's vertical of body orientations (..., 4) w, x, y, z."""
    w, x, y, z = np.moveaxis(np.asarray(quat, dtype=float), -1, 0)
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


class GaitController:
    """One gait, its correction law and the correction's state for ``batch`` robots.

    ``base_tips`` (batch or 1, n_period, nlegs, 3) and ``step_length`` (batch or 1,) are
    the gait's; ``y_rel`` (n_period, nlegs) its stride shape; ``sides`` (nlegs,) -1/+1.
    ``law`` None is the open-loop gait (the correction stays 0). ``columns``: the (leg index,
    joint index) of each servo in the order ``setpoints`` gives them (gait.json ``joints``).
    ``chain`` (gait.json ``chain``): the numerical IK of a robot of any leg layout, in place
    of the closed-form one of ``link_lengths``: ``frames`` (per leg: ``origin``, ``outward``,
    ``up``; one ``forward``), ``solver`` (``ChainIK.as_dict``), ``tol`` and ``max_iter``.
    ``heading`` (gait.json ``heading_quat``, w, x, y, z): the gait's frame (x right, y
    forward, z up) in the chassis frame the IMU reports, where the two differ (an uploaded
    robot whose forward is not its trunk's y axis); None: the same frame. ``levers``
    (nlegs, 2; gait.json ``balance_levers_m``): each foot's nominal place (right, forward) in
    metres, for the balance correction."""

    def __init__(self, base_tips, y_rel, step_length, sides, link_lengths, stride_bounds, update_steps: int,
                 law: dict | None = None, batch: int = 1, columns=None, chain: dict | None = None, heading=None,
                 levers=None):
        base = np.asarray(base_tips, dtype=float)
        self.base_tips = np.broadcast_to(base if base.ndim == 4 else base[None], (batch,) + base.shape[-3:])
        self.y_rel = np.asarray(y_rel, dtype=float)
        self.step_length = np.broadcast_to(np.asarray(step_length, dtype=float).reshape(-1), (batch,))
        self.sides = np.asarray(sides, dtype=float)
        self.link_lengths = tuple(float(v) for v in link_lengths)
        self.stride_bounds = (float(stride_bounds[0]), float(stride_bounds[1]))
        self.n_period = self.y_rel.shape[0]
        self.update_steps = int(update_steps)
        self.law = None if law is None else {k: float(law[k] if k not in BALANCE else law.get(k, 0.0))
                                             for k in GAINS + LIMITS} | {"odometry": bool(law.get("odometry", True))}
        self.balance = self.law is not None and (self.law["balance_gain"] > 0 or self.law["balance_integral_gain"] > 0)
        nlegs = self.y_rel.shape[1]
        if self.balance:
            if levers is None:
                raise ValueError("balance needs each foot's place (levers)")
            lv = np.asarray(levers, dtype=float).reshape(nlegs, 2)
            self.levers = lv - lv.mean(axis=0)  # about the feet's centroid: the offsets sum to 0
        self.batch = batch
        self.columns = None if columns is None else np.asarray(columns, dtype=int).reshape(-1, 2)
        self.heading = None if heading is None else np.asarray(heading, dtype=float)
        self.chain = None
        if chain is not None:
            f = chain["frames"]
            self.chain = {"ik": ChainIK.from_dict(chain["solver"]), "tol": float(chain["tol"]),
                          "max_iter": int(chain["max_iter"]), "origin": np.asarray(f["origin"], dtype=float),
                          "outward": np.asarray(f["outward"], dtype=float),
                          "forward": np.asarray(f["forward"], dtype=float), "up": np.asarray(f["up"], dtype=float)}
            if self.columns is not None:  # (leg, joint) -> the column of the legs' joints, in order
                starts = np.array([c.start for c in self.chain["ik"].cols])
                self.flat = starts[self.columns[:, 0]] + self.columns[:, 1]
        z = np.zeros(batch)
        # per robot: heading and position at the walk's start; the integrals; the command
        # in force before the last update and the one the last update set ([stride, crab])
        self.yaw0, self.pos0 = z.copy(), np.zeros((batch, 2))
        self.sum_yaw, self.sum_lat = z.copy(), z.copy()
        width = 2 + (nlegs if self.balance else 0)  # [stride, crab] and, with balance, each tip's height offset
        self.sum_tilt = np.zeros((batch, nlegs))
        self.cmd_prev, self.cmd = np.zeros((batch, width)), np.zeros((batch, width))

    @classmethod
    def from_json(cls, path, batch: int = 1) -> "GaitController":
        """The controller of a bundle's ``gait.json``."""
        return cls.from_dict(json.loads(Path(path).read_text()), batch)

    @classmethod
    def from_dict(cls, g: dict, batch: int = 1) -> "GaitController":
        return cls(g["base_tips_m"], g["y_rel"], g["step_length_m"], g["sides"], g["link_lengths_m"],
                   g["stride_bounds_m"], g["update_steps"], g["law"], batch,
                   [[j["leg_index"], j["joint_index"]] for j in g["joints"]], g.get("chain"), g.get("heading_quat"),
                   g.get("balance_levers_m"))

    # -- the correction ----------------------------------------------------------------
    def start(self, quat, pos=None, rows=None) -> None:
        """The walk starts (tick 0): the heading and position to hold are the current ones."""
        rows = slice(None) if rows is None else rows
        self.yaw0[rows] = yaw_of(self._gait_frame(quat))
        if pos is not None:
            self.pos0[rows] = np.asarray(pos, dtype=float)[..., :2]
        self.sum_yaw[rows] = self.sum_lat[rows] = 0.0
        self.sum_tilt[rows] = 0.0
        self.cmd_prev[rows] = self.cmd[rows] = 0.0

    def update(self, quat, pos=None, rows=None) -> np.ndarray:
        """A new command ([stride difference m, crab stride m] per robot, then with balance
        each tip's height offset m) from the latest IMU orientation (w, x, y, z) and, with
        odometry, position (x, y[, z]) in the frame the walk started in; it is ramped in
        over the next ``update_steps`` ticks."""
        rows = np.arange(self.batch) if rows is None else np.asarray(rows)
        self.cmd_prev[rows] = self.cmd[rows]
        if self.law is None:
            return self.cmd[rows]
        L = self.law
        e = _wrap(yaw_of(self._gait_frame(quat)) - self.yaw0[rows])
        self.sum_yaw[rows] = _accumulate(self.sum_yaw[rows], e, L["yaw_integral_gain"], L["stride_limit_m"])
        d = np.clip(L["yaw_gain"] * e + L["yaw_integral_gain"] * self.sum_yaw[rows],
                    -L["stride_limit_m"], L["stride_limit_m"])
        c = np.zeros_like(d)
        if L["odometry"] and pos is not None:
            dp = np.asarray(pos, dtype=float)[..., :2] - self.pos0[rows]
            psi0 = self.yaw0[rows]
            s = np.cos(psi0) * dp[..., 0] + np.sin(psi0) * dp[..., 1]  # across the start heading, + to the right
            self.sum_lat[rows] = _accumulate(self.sum_lat[rows], s, L["lateral_integral_gain"], L["lateral_limit_m"])
            c = -np.clip(L["lateral_gain"] * s + L["lateral_integral_gain"] * self.sum_lat[rows],
                         -L["lateral_limit_m"], L["lateral_limit_m"])
        if not self.balance:
            self.cmd[rows] = np.stack([d, c], axis=-1)
            return self.cmd[rows]
        g = self._gait_frame(quat)
        w, x, y, z = np.moveaxis(np.asarray(g, dtype=float), -1, 0)
        r_zx, r_zy = 2 * (x * z - w * y), 2 * (y * z + w * x)  # the world height of the gait frame's x, y axes
        h = r_zx[..., None] * self.levers[:, 0] + r_zy[..., None] * self.levers[:, 1]  # (robots, nlegs)
        self.sum_tilt[rows] = _accumulate(self.sum_tilt[rows], h, L["balance_integral_gain"], L["balance_limit_m"])
        dz = np.clip(L["balance_gain"] * h + L["balance_integral_gain"] * self.sum_tilt[rows],
                     -L["balance_limit_m"], L["balance_limit_m"])
        self.cmd[rows] = np.concatenate([np.stack([d, c], axis=-1), dz], axis=-1)
        return self.cmd[rows]

    def _gait_frame(self, quat) -> np.ndarray:
        """The gait frame's orientation (..., 4) from the chassis' (IMU) orientation."""
        if self.heading is None:
            return quat
        q, h = np.asarray(quat, dtype=float), self.heading
        w, x, y, z = np.moveaxis(q, -1, 0)
        hw, hx, hy, hz = h
        return np.stack([w * hw - x * hx - y * hy - z * hz, w * hx + x * hw + y * hz - z * hy,
                         w * hy - x * hz + y * hw + z * hx, w * hz + x * hy - y * hx + z * hw], axis=-1)

    # -- set-points --------------------------------------------------------------------
    def commands(self, j0: int, j1: int, rows=None) -> np.ndarray:
        """The command in force at ticks [j0, j1) (robots, T, 2): the ramp from the previous
        command to the last one over the ``update_steps`` ticks after the last update."""
        rows = slice(None) if rows is None else rows
        j = np.arange(j0, j1)
        w = np.minimum((j % self.update_steps + 1) / self.update_steps, 1.0)[None, :, None]
        return self.cmd_prev[rows][:, None] + w * (self.cmd[rows] - self.cmd_prev[rows])[:, None]

    def tips(self, j0: int, j1: int, rows=None) -> np.ndarray:
        """Corrected tip targets (robots, T, nlegs, 3) in the hip frames at ticks [j0, j1)."""
        rows_ = slice(None) if rows is None else rows
        k = np.arange(j0, j1) % self.n_period
        base = self.base_tips[rows_][:, k]
        if self.law is None:
            return base
        cmd = self.commands(j0, j1, rows)
        L = self.step_length[rows_][:, None, None]
        y_rel = self.y_rel[k][None]
        # the gait's bounds, widened to hold its own stride (a zero command leaves it as it is)
        lo, hi = np.minimum(self.stride_bounds[0], L), np.maximum(self.stride_bounds[1], L)
        stride = np.clip(L - self.sides * cmd[..., 0:1], lo, hi)
        out = np.array(base)
        out[..., 1] += 0.5 * (stride - L) * y_rel
        out[..., 0] += self.sides * 0.5 * cmd[..., 1:2] * y_rel
        if self.balance:
            out[..., 2] += cmd[..., 2:]
        return out

    def joint_angles(self, j0: int, j1: int, rows=None) -> np.ndarray:
        """Coxa, femur, tibia set-points (robots, T, nlegs, 3) in radians at ticks [j0, j1);
        with ``chain``, every leg joint's (robots, T, joints), legs in order."""
        return self.angles_of(self.tips(j0, j1, rows))

    def setpoints(self, j0: int, j1: int, rows=None) -> np.ndarray:
        """The servo set-points (robots, T, servos) in radians at ticks [j0, j1), in the order
        of ``columns`` (gait.json ``joints``)."""
        return self.named(self.joint_angles(j0, j1, rows))

    def named(self, q: np.ndarray) -> np.ndarray:
        """(..., nlegs, 3) joint angles (with ``chain``: (..., joints)) -> (..., servos) in the
        order of ``columns``."""
        if self.chain is not None:
            return q[..., self.flat]
        return q[..., self.columns[:, 0], self.columns[:, 1]]

    def settle_pose(self) -> np.ndarray:
        """The set-points (robots, nlegs, 3) the robot stands on before the walk (tick 0's
        open-loop pose)."""
        return self.angles_of(self.base_tips[:, 0])

    def angles_of(self, tips: np.ndarray) -> np.ndarray:
        if self.chain is not None:  # hip frames -> the trunk's, then the legs' numerical IK
            c = self.chain
            return c["ik"].solve(trunk_targets(tips, c), tol=c["tol"], max_iter=c["max_iter"]).q
        leg = np.array(tips)
        leg[..., 1] *= self.sides  # hip frame -> leg frame (left legs are turned 180 deg about z)
        return leg_ik(leg, self.link_lengths)


def trunk_targets(tips: np.ndarray, frames) -> np.ndarray:
    """Tips (..., nlegs, 3) in the legs' hip frames -> foot targets in the trunk's frame:
    origin (nlegs, 3) + x outward (nlegs, 3) + y forward (3,) + z up (3,)."""
    return (np.asarray(frames["origin"]) + tips[..., 0:1] * np.asarray(frames["outward"])
            + tips[..., 1:2] * np.asarray(frames["forward"]) + tips[..., 2:3] * np.asarray(frames["up"]))


def _accumulate(total: np.ndarray, e: np.ndarray, gain: float, limit: float) -> np.ndarray:
    """The integral plus ``e``, held where its term alone would pass the limit."""
    if gain <= 0.0:
        return total
    cap = limit / gain
    return np.clip(total + e, -cap, cap)


def walk(ctl: GaitController, readings, n_walk: int) -> np.ndarray:
    """Every servo set-point of a walk of ``n_walk`` ticks (robots, n_walk, servos), given the
    readings ``readings(j) -> (quat, pos)`` at each update tick j (the state the robot is in
    at tick j); tick 0's reading starts the correction. A robot's control loop does the
    same, one tick at a time: at each update tick read the IMU (and odometry), call
    ``start`` (tick 0) or ``update``, then send ``setpoints(j, j + 1)`` every servo tick."""
    out = np.empty((ctl.batch, n_walk, len(ctl.columns)))
    for j0 in range(0, n_walk, ctl.update_steps):
        quat, pos = readings(j0)
        if j0 == 0:
            ctl.start(quat, pos)
        else:
            ctl.update(quat, pos)
        j1 = min(j0 + ctl.update_steps, n_walk)
        out[:, j0:j1] = ctl.setpoints(j0, j1)
    return out

"""What a lab needs to run a recovered gait on the robot: the bundle's ``controller/`` folder.

- ``gait_controller.py``: the controller the simulation ran (app/jobs/recovery/gait_controller.py,
  copied byte for byte: numpy only);
- ``gait.json``: its gait (one period of tip targets, the stride shape), the correction law,
  the servo rate, the servos (joint names in order, zero offsets, ranges, gains, torque limits);
- ``setpoints.json`` / ``setpoints.csv``: the open-loop set-points per named joint at the
  servo rate (the settling pose, then one gait period, repeated);
- ``simulated_walk.csv``: every set-point the simulation sent over the answer's walk (open or
  closed loop) with the chassis' position and orientation after each tick;
- ``check_controller.py``: replays that walk through the controller from the same readings
  and reports the largest difference (gaitmend's tests require <= 1e-9 rad);
- ``README.md``: how to drive it from a control loop, and what was not modelled.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import mujoco
import numpy as np

from app.jobs.recovery import gait_controller
from app.robots import chain_ik, ik

FILES = {
    "controller/README.md": "how to run the gait on the robot: the control loop, the files below, what was not modelled",
    "controller/gait_controller.py": "the gait's set-points and its closed-loop correction: the module the simulation "
                                     "ran, numpy only (no gaitmend import)",
    "controller/ik.py": "the closed-form leg inverse kinematics gait_controller.py imports: gaitmend's own "
                        "app/robots/ik.py, the file the simulation ran, numpy only",
    "controller/chain_ik.py": "the numerical leg inverse kinematics gait_controller.py imports for a robot of any "
                              "leg layout: gaitmend's own app/robots/chain_ik.py, numpy only",
    "controller/gait.json": "the controller's data: one gait period of tip targets, the correction law (gains, limits, "
                            "update interval), the servo rate, the servos in order with zero offsets, ranges and gains",
    "controller/setpoints.json": "open-loop joint set-points (rad) per named servo at the servo rate: the settling pose "
                                 "and one gait period (repeat it)",
    "controller/setpoints.csv": "the same, one row per servo tick: tick, time_s, one column per servo (rad)",
    "controller/simulated_walk.csv": "every set-point the simulation sent over the answer's walk (rad, per servo) and "
                                     "the chassis' position (m) and orientation (w, x, y, z) after each tick",
    "controller/check_controller.py": "replays simulated_walk.csv through gait_controller.py from the same readings "
                                      "and prints the largest set-point difference",
}

ANGLES = {"builtin": """Angles are radians from the model's zero pose (`zero_offset_rad`, all 0 here: every leg
straight out from its hip, horizontal; coxa about the vertical, femur and tibia about the
leg's horizontal axis, positive lifting the tip); left legs' frames are turned 180 deg about
the vertical, so the same angle moves a left and a right leg the same way.""",
          "upload": """Set-points are the joints' positions as your model defines them (radians for a hinge,
metres for a slide; `zero_offset_rad` is each joint's reference position in the model);
they come from your legs' numerical inverse kinematics (`chain_ik.py`, the chains in
`gait.json` `chain`), the solver the simulation ran."""}

README = """# Running the recovered gait on the robot

This folder is the gait gaitmend found, as a controller you can run without gaitmend
(Python 3 and numpy). The job ran it in {mode}.

## The servos

`gait.json` `joints` lists the servos in the order every set-point table uses: {joints}.
{angles} Each servo's PID
gains (`kp_nm_per_rad`, `kd_nm_s_per_rad`, `ki_nm_per_rad_s`) and torque limit are the
simulated ones: map them to your servos' own units. Set-points are for a servo rate of
{rate:g} Hz (one tick per simulation step). Locked joints of the damage have no servo and
no column.

## Open loop

`setpoints.csv` / `setpoints.json`: hold the settling pose (tick -1) for {settle} ticks, then
send the period's {period} rows at the servo rate, over and over. That is the paper's gait.

## Closed loop (heading and drift correction)

```python
import numpy as np
from gait_controller import GaitController

ctl = GaitController.from_json("gait.json")
send(ctl.named(ctl.settle_pose())[0])            # hold it for gait.json settle_steps ticks
j = 0
while walking:                                   # one pass per servo tick
    if j % ctl.update_steps == 0:                # every {update} ticks
        quat = imu_quaternion()                  # (w, x, y, z) of the chassis in a world frame
        pos = odometry_xy()                      # chassis position (m), or None for IMU only
        (ctl.start if j == 0 else ctl.update)(np.array([quat]), None if pos is None else np.array([pos]))
    send(ctl.setpoints(j, j + 1)[0, 0])          # one set-point per servo, gait.json order
    j += 1
```

The correction holds the heading and the line the walk started on: a stride difference
between the left and right legs turns the robot back, a sideways stride carries it back to
its line (gait.json `law`: gains, limits; each leg's stride stays within `stride_bounds_m`).
Without odometry, only the heading is corrected.

`check_controller.py` replays `simulated_walk.csv` (what the simulation sent, and the
chassis' state after each tick) through `gait_controller.py` and prints the largest
difference: run it with `python check_controller.py` in this folder to check your copy.

## Not modelled

Actuation and sensing latency (the correction reads the state at the update tick and the
servos track the set-point at once), backlash and compliance in the gear trains, servo
deadbands, IMU noise, bias and drift, odometry error (the simulation used the true chassis
position), and any floor, friction, mass or servo error beyond the job's robustness cases
and held-out ranges (result.json `robustness`). The servo model is MuJoCo's PID with the
gains above and the gear train as joint armature.
"""

CHECK = """\"\"\"Replays simulated_walk.csv through gait_controller.py from the same readings; prints the
largest difference between its set-points and the simulation's (radians); exit 1 above 1e-9.\"\"\"
import json
import sys
from pathlib import Path

import numpy as np

here = Path(__file__).resolve().parent
sys.path.insert(0, str(here))
from gait_controller import GaitController, walk  # noqa: E402

g = json.loads((here / "gait.json").read_text())
rows = np.loadtxt(here / "simulated_walk.csv", delimiter=",", skiprows=1, ndmin=2)
nj, settle = len(g["joints"]), g["settle_steps"]
sent, state = rows[:, 2:2 + nj], rows[:, 2 + nj:]
ctl = GaitController.from_json(here / "gait.json")


def readings(j):  # the chassis at tick j: the state after the tick before it
    r = state[settle + j - 1]
    return r[None, 3:7], r[None, 0:3]


ours = walk(ctl, readings, len(rows) - settle)[0]
diff = max(float(np.abs(ours - sent[settle:]).max()), float(np.abs(sent[:settle] - ctl.named(ctl.settle_pose())[0]).max()))
print(json.dumps({"ticks": len(rows), "max_abs_diff_rad": diff}))
sys.exit(0 if diff <= 1e-9 else 1)
"""


def _places(ev) -> dict[int, tuple[int, int]]:
    """Actuator -> (leg index, joint index) where the controller finds it: the built-in
    robots' (legs, 3) ctrl columns, or an uploaded robot's columns of every leg joint in
    order (its controller chain's legs)."""
    cols = np.asarray(ev.ctrl_cols)
    if cols.ndim == 2:
        return {int(cols[li, ji]): (int(li), int(ji)) for li, ji in zip(*np.nonzero(cols >= 0))}
    sizes = [sum(len(b["joints"]) for b in c["bodies"]) for c in ev.controller_chain["solver"]["chains"]]
    starts = np.cumsum([0] + sizes)
    out = {}
    for j, a in enumerate(cols):
        if a >= 0:
            leg = int(np.searchsorted(starts, j, side="right") - 1)
            out[int(a)] = (leg, int(j - starts[leg]))
    return out


def servos(model: mujoco.MjModel, places: dict[int, tuple[int, int]]) -> list[dict]:
    """The actuated joints in actuator (= set-point column) order, with where the controller
    finds each (leg index, joint index), the model's zero offset and range, and the servo's
    gains as MuJoCo's pid actuator holds them (bias -kp, -kd; gain ki) and torque limit."""
    out = []
    for a in range(model.nu):
        li, ji = places[a]
        j = int(model.actuator_trnid[a, 0])
        out.append({"name": mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j),
                    "actuator": mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a),
                    "leg_index": li, "joint_index": ji,
                    "zero_offset_rad": float(model.qpos0[model.jnt_qposadr[j]]),
                    "range_rad": [float(v) for v in model.jnt_range[j]],
                    "kp_nm_per_rad": float(-model.actuator_biasprm[a, 1]),
                    "kd_nm_s_per_rad": float(-model.actuator_biasprm[a, 2]),
                    "ki_nm_per_rad_s": float(model.actuator_gainprm[a, 0]),
                    "torque_limit_nm": float(model.actuator_forcerange[a, 1])})
    return out


def gait_json(ev, x: np.ndarray, stride_bounds, law) -> dict:
    """gait.json for the answer ``x`` (1, nparams) of evaluator ``ev`` (its law or None)."""
    n = len(ev.legs)
    update = law.update_steps(ev.n_period, ev.seq.sigma) if law is not None else ev.n_period
    return {"schema": 1, "servo_rate_hz": 1.0 / ev.dt, "timestep_s": ev.dt, "settle_steps": ev.n_settle,
            "walk_steps": ev.n_walk, "period_steps": ev.n_period, "update_steps": update,
            "legs": [int(l) for l in ev.legs], "sides": [int(s) for s in ev.sides],
            "link_lengths_m": [float(v) for v in getattr(ev.robot.geometry, "link_lengths", ())],
            "chain": getattr(ev, "controller_chain", None), "heading_quat": getattr(ev, "controller_heading", None),
            "step_length_m": float(x[0, 2 * n]), "stride_bounds_m": [float(v) for v in stride_bounds],
            "law": None if law is None else law.as_dict(),
            "balance_levers_m": ev.balance_levers().tolist(),
            "joints": servos(ev.model, _places(ev)),
            "base_tips_m": ev.period_tips(x)[0].tolist(), "y_rel": ev.stride_shape().tolist()}


def _csv(header: list[str], rows: np.ndarray, ints: int = 1) -> str:
    buf = io.StringIO()
    buf.write(",".join(header) + "\n")
    fmt = ",".join(["%d"] * ints + ["%.17g"] * (rows.shape[1] - ints))
    np.savetxt(buf, rows, fmt=fmt)
    return buf.getvalue()


def controller_files(ev, x: np.ndarray, stride_bounds, law, trace: dict) -> dict[str, str]:
    """The ``controller/`` files for the answer ``x`` walked by ``ev`` (``trace``: its
    recorded walk, ``GaitEvaluator.trace``)."""
    g = gait_json(ev, x, stride_bounds, law)
    names = [j["name"] for j in g["joints"]]
    ctl = gait_controller.GaitController.from_dict(g | {"law": None})  # the open-loop gait
    settle = ctl.named(ctl.settle_pose())[0]
    period = ctl.setpoints(0, ev.n_period)[0]
    ticks = np.arange(-1, ev.n_period)  # -1: the settling pose, held for settle_steps ticks
    times = np.where(ticks < 0, -ev.n_settle * ev.dt, ticks * ev.dt)
    table = np.column_stack([ticks, times, np.vstack([settle, period])])
    rows = trace["ctrl"].shape[0]
    steps = np.arange(rows)
    walk = np.column_stack([steps, (steps - ev.n_settle + 1) * ev.dt, trace["ctrl"], trace["qpos"][:, :7]])
    setpoints = {"servo_rate_hz": g["servo_rate_hz"], "joints": names,
                 "zero_offsets_rad": [j["zero_offset_rad"] for j in g["joints"]],
                 "settle_steps": ev.n_settle, "settle_pose_rad": settle.tolist(),
                 "period_steps": ev.n_period, "period_rad": period.tolist()}
    return {
        "controller/README.md": README.format(rate=g["servo_rate_hz"], settle=ev.n_settle,
                                                          period=ev.n_period, update=g["update_steps"],
                                                          mode="closed loop" if law else "open loop",
                                                          joints=", ".join(names),
                                                          angles=ANGLES["upload" if g["chain"] else "builtin"]),
        "controller/gait_controller.py": Path(gait_controller.__file__).read_text(),
        "controller/ik.py": Path(ik.__file__).read_text(),
        "controller/chain_ik.py": Path(chain_ik.__file__).read_text(),
        "controller/gait.json": json.dumps(g),
        "controller/setpoints.json": json.dumps(setpoints),
        "controller/setpoints.csv": _csv(["tick", "time_s"] + names, table),
        "controller/simulated_walk.csv": _csv(["step", "time_s"] + names + ["x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"],
                                              walk),
        "controller/check_controller.py": CHECK,
    }


def upload_files(job) -> dict[str, str]:
    """An uploaded robot's ``controller/`` files, made at the end of its job while its
    evaluator is at hand (the bundle writer has no stored robot to build it again)."""
    law = job.ev.cfg.law
    bounds = law.stride_bounds if law is not None else (job.lower[-2], job.upper[-2])
    return controller_files(job.ev, job.searches["search"].best_x[None], bounds, law, job.traces["best"])

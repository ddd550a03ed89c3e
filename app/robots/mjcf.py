"""The MJCF building blocks every built-in robot uses, so that each robot module says only
what is its own (links, joints, feet) and the common settings are written once."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import mujoco

CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}


def new_spec(name: str, timestep: float, cone: str) -> mujoco.MjSpec:
    """An empty world: implicitfast integration (stable with stiff position servos),
    the given friction cone, angles in radians."""
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = CONES[cone]
    spec.compiler.degree = False
    return spec


def limit_force(act: mujoco.MjsActuator, limit: float) -> None:
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-limit, limit]


def add_pid_servo(spec: mujoco.MjSpec, name: str, joint: str, kp: float, kv: float, force_limit: float,
                  ki: float | None = None) -> mujoco.MjsActuator:
    """A position servo (PID on the joint angle, control range from the joint's), its
    force limited to +-force_limit."""
    act = spec.add_actuator(name=name, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    gains = {"kp": kp, "kv": kv} | ({"ki": ki} if ki is not None else {})
    act.set_to_pid(**gains, inheritrange=1.0, ctrlspec=int(mujoco.mjtCtrlInput.mjINPUT_POS))
    limit_force(act, force_limit)
    return act


def add_frame_sensors(spec: mujoco.MjSpec, sensors: Iterable[tuple[str, str]], objtype: mujoco.mjtObj,
                      objname: str) -> None:
    """Sensors on one object, in the order given: (name, "pos" | "quat" | "com")."""
    types = {"pos": mujoco.mjtSensor.mjSENS_FRAMEPOS, "quat": mujoco.mjtSensor.mjSENS_FRAMEQUAT,
             "com": mujoco.mjtSensor.mjSENS_SUBTREECOM}
    for name, what in sensors:
        spec.add_sensor(name=name, type=types[what], objtype=objtype, objname=objname)


TORSO_SENSORS = (("torso_pos", "pos"), ("torso_quat", "quat"), ("com_pos", "com"))


def add_torso_sensors(spec: mujoco.MjSpec) -> None:
    """The trunk's position, orientation and the whole robot's centre of mass."""
    add_frame_sensors(spec, TORSO_SENSORS, mujoco.mjtObj.mjOBJ_BODY, "torso")


def describe_legs(name: str, description: str, legs: Sequence, joints: Sequence[str], side: Callable[[object], float],
                  hip: Callable[[object], Sequence[float]]) -> dict:
    """A catalogue entry (for /api/robots): legs, joints, each leg's side (left where the
    side sign is positive) and hip position."""
    return {
        "name": name,
        "description": description,
        "legs": list(legs),
        "joints": list(joints),
        "leg_sides": {str(l): ("left" if side(l) > 0 else "right") for l in legs},
        "hips_m": {str(l): [float(v) for v in hip(l)] for l in legs},
    }

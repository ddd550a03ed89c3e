"""The robot a repertoire is built for, in one form for every robot with a leg map: the
damaged model with a position servo on every driven leg joint, the joints' ranges and
stance, the feet and the fall test's contact sensors, and the first state of every trial.

- **Built-in** (``jethexa``): the recovery hexapod as the robot layer builds it
  (``RobotEntry.model``: its PID servos, feet and fall sensors), damaged through
  app/robots/damage.py; the spec's leg-map names (``leg3``, ``leg2_femur``) are translated
  to the built-in's leg numbers here, at the edge. Stance: the robot's nominal stance.
- **Uploaded**: the stored robot made walkable (app/robots/walkable.py ``make_walkable``,
  damage by the leg map's names). Stance: the leg map's stance where it gives one, else
  the model's reference pose clipped to the joint ranges.

Both get two sensors per servo (its force and its joint's velocity) for the energy, and
start each trial standing in the stance with the lowest foot on the floor.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.legmap import LegMapError, Robot
from app.robots.walkable import make_walkable

OBJ = mujoco.mjtObj
STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
CLEARANCE_M = 0.002  # the lowest foot starts this far above the floor


@dataclasses.dataclass
class Body:
    name: str
    mspec: mujoco.MjSpec
    model: mujoco.MjModel
    joints: list[str]  # the driven joint of each servo, in actuator order
    lo: np.ndarray
    hi: np.ndarray
    stance: np.ndarray
    legs: list[str]  # the remaining legs, by leg-map name, in the descriptor's order
    feet: list[str]  # each remaining leg's foot contact sensor, in the same order
    state0: np.ndarray  # the first state of every trial (mjSTATE_FULLPHYSICS)
    info: dict  # what the summary says of the robot


def _builtin_legs(robot: str):
    from app.robots.catalog import get_robot

    entry = get_robot(robot)
    return entry, entry.leg_map()


def builtin_damage_error(robot: str, damage) -> str | None:
    """Why a built-in robot cannot take ``damage`` (a leg or joint its leg map lacks, no
    leg left), worded with the field; None when it can."""
    _, legs = _builtin_legs(robot)
    return _damage_error(damage, legs)


def _damage_error(damage, legs) -> str | None:
    try:
        damage.check(legs)
    except LegMapError as e:
        return f"damage.{e}"
    if len(damage.lost_legs) >= len(legs.legs):
        return "damage.lost_legs: at least one leg must be left"
    return None


def _add_energy_sensors(mspec: mujoco.MjSpec, actuators: list[str], joints: list[str]) -> None:
    for k, (a, j) in enumerate(zip(actuators, joints)):
        mspec.add_sensor(name=f"rep_force_{k}", type=mujoco.mjtSensor.mjSENS_ACTUATORFRC, objtype=OBJ.mjOBJ_ACTUATOR,
                         objname=a)
        mspec.add_sensor(name=f"rep_speed_{k}", type=mujoco.mjtSensor.mjSENS_JOINTVEL, objtype=OBJ.mjOBJ_JOINT,
                         objname=j)


def _servos(model: mujoco.MjModel) -> tuple[list[str], list[str]]:
    acts = [mujoco.mj_id2name(model, OBJ.mjOBJ_ACTUATOR, a) for a in range(model.nu)]
    joints = [mujoco.mj_id2name(model, OBJ.mjOBJ_JOINT, int(model.actuator_trnid[a, 0])) for a in range(model.nu)]
    return acts, joints


def _ranges(model: mujoco.MjModel, stance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each servo's range: its control range, else its joint's, else +-90 deg about the stance."""
    lo, hi = np.empty(model.nu), np.empty(model.nu)
    for a in range(model.nu):
        j = int(model.actuator_trnid[a, 0])
        if model.actuator_ctrllimited[a]:
            lo[a], hi[a] = model.actuator_ctrlrange[a]
        elif model.jnt_limited[j]:
            lo[a], hi[a] = model.jnt_range[j]
        else:
            lo[a], hi[a] = stance[a] - math.pi / 2, stance[a] + math.pi / 2
    return lo, hi


def _first_state(model: mujoco.MjModel, stance: np.ndarray, tips: list[str], foot_radius: float) -> np.ndarray:
    """Standing in the stance, the trunk level as in the model, the lowest foot just above the floor."""
    d = mujoco.MjData(model)
    adr = [model.jnt_qposadr[int(model.actuator_trnid[a, 0])] for a in range(model.nu)]
    d.qpos[adr] = stance
    d.qpos[0:2] = 0.0
    mujoco.mj_kinematics(model, d)
    sites = [mujoco.mj_name2id(model, OBJ.mjOBJ_SITE, s) for s in tips]
    low = float(np.min(d.site_xpos[sites, 2]))
    d.qpos[2] += foot_radius + CLEARANCE_M - low
    mujoco.mj_forward(model, d)
    out = np.empty(mujoco.mj_stateSize(model, STATE))
    mujoco.mj_getState(model, d, out, STATE)
    return out


def build(spec, stored: Robot | None = None, timestep: float | None = None) -> Body:
    """The robot of ``spec`` under its damage at ``timestep`` (default the spec's);
    ``stored``: the uploaded robot (``RunContext.load_robot``) when ``spec.robot`` is one."""
    dt = spec.sim.timestep_s if timestep is None else timestep
    if stored is None:
        return _builtin(spec, dt)
    return _uploaded(spec, stored, dt)


def _builtin(spec, dt: float) -> Body:
    entry, legs = _builtin_legs(spec.robot)
    mspec, model = entry.model(spec.damage)
    acts, joints = _servos(model)
    _add_energy_sensors(mspec, acts, joints)
    mspec.option.timestep = dt
    model = mspec.compile()
    nominal = entry.nominal_stance()
    by_joint = {f"leg{n}_{jn}": q for n, qs in nominal.items() for jn, q in zip(("coxa", "femur", "tibia"), qs)}
    stance = np.array([by_joint[j] for j in joints])
    lo, hi = _ranges(model, stance)
    kept = [l.name for l in legs.legs if l.name not in spec.damage.lost_legs]
    state0 = _first_state(model, np.clip(stance, lo, hi), [f"{l}_tip" for l in kept], entry.geometry.foot_radius)
    info = {"name": spec.robot, "built_in": True, "legs": kept, "servos": len(joints),
            "total_mass_kg": float(model.body_subtreemass[1])}
    return Body(spec.robot, mspec, model, joints, lo, hi, stance, kept, [f"{l}_foot_touch" for l in kept], state0,
                info)


def _uploaded(spec, stored: Robot, dt: float) -> Body:
    walk = make_walkable(stored, spec.damage, dt)
    mspec = walk.spec
    model = mspec.compile()
    acts, joints = _servos(model)
    _add_energy_sensors(mspec, acts, joints)
    mspec.option.timestep = dt
    model = mspec.compile()
    given = {j: q for l in walk.legs.legs if l.stance is not None for j, q in zip(l.joints, l.stance)}
    qpos0 = np.array([model.qpos0[model.jnt_qposadr[mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, j)]] for j in joints])
    stance = np.array([given.get(j, q) for j, q in zip(joints, qpos0)])
    lo, hi = _ranges(model, stance)
    order = sorted(walk.numbers, key=walk.numbers.get)
    state0 = _first_state(model, np.clip(stance, lo, hi), [f"leg{walk.numbers[l]}_tip" for l in order],
                          walk.foot_radius)
    info = {"name": stored.name, "built_in": False, "legs": order, "servos": len(joints),
            "total_mass_kg": walk.total_mass,
            "stance": "leg map" if given else "reference pose clipped to the joint ranges",
            "upload_actuators": walk.upload_actuators}
    return Body(spec.robot, mspec, model, joints, lo, hi, stance, order,
                [f"leg{walk.numbers[l]}_foot_touch" for l in order], state0, info)


def uploaded_error(spec, legs_json: dict) -> str | None:
    """Why ``spec``'s damage cannot be made on an uploaded robot of this leg map, else None."""
    from app.robots.legmap import LegMap

    try:
        legs = LegMap.parse(legs_json)
    except LegMapError as e:
        return f"damage: {e}"
    return _damage_error(spec.damage, legs)

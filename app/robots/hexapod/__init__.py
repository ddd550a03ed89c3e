"""JetHexa-like 18-DoF hexapod, built procedurally with MjSpec.

Numbering (papers README, derived from the text of paper 000 since its Fig. 1 is
missing): odd legs on the left (-X), even legs on the right (+X); legs (1, 2) are the
front pair, (3, 4) the middle pair, (5, 6) the rear pair; forward is +Y. Tripod groups
L1 = {1, 4, 5} and L2 = {2, 3, 6} then contain no two neighbouring legs, as the paper
requires.

Dimensions and masses. Hiwonder publishes the JetHexa as a ~2 kg hexapod with three
35 kg*cm (3.4 N*m) bus servos per leg and a hexagonal chassis; link lengths are not
published. We use coxa/femur/tibia = 45/77/123 mm, the lengths of Hiwonder's own
hexapod legs of that servo class, which also put the paper's foot-position bounds
(x0 in [0.09, 0.13] m from the hip, Sec. IV-B) in the middle of the leg's workspace at
the paper's stance height. Body 0.14 x 0.26 m, 1.2 kg (chassis, Jetson Nano, battery);
per leg 0.04/0.06/0.03 kg (servo plus bracket per link) -> 1.98 kg in all.

Actuation. MuJoCo 4's native ``pid`` actuator is the paper's joint PID exactly
(Kp 500, Kd 1, Ki 10, Sec. IV-B) and, unlike the old ``mujoco.pid`` plugin, keeps its
integral in ``act`` so it is part of the state that ``mujoco.rollout`` carries; the
derivative acts on joint velocity and is integrated implicitly (implicitfast). The
servos' gear trains are modelled as joint armature (rotor inertia x ratio^2 ~ 5e-3
kg*m^2 for a ~1:300 hobby servo), which is also what keeps Kp = 500 stable at a 4 ms
step on links this light.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.mjcf import add_pid_servo, add_torso_sensors, new_spec

LEG_IDS = (1, 2, 3, 4, 5, 6)
# The recovery job's default step, chosen by the convergence rule (docs/recovery.md,
# "Timestep"): recovered gaits, not only the nominal tripod, move less than the stated
# tolerance when it is halved. 4 ms and 2 ms fail it on answers searched at those steps,
# 1 ms passes (tests/jobs/test_recovery_experiments.py checks it on the documented answers).
DEFAULT_TIMESTEP = 0.001
JOINT_NAMES = ("coxa", "femur", "tibia")


@dataclasses.dataclass(frozen=True)
class LegGeometry:
    leg: int
    hip: tuple[float, float, float]  # hip (coxa axis) position in the body frame
    side: int  # -1 left (odd), +1 right (even)


@dataclasses.dataclass(frozen=True)
class HexapodGeometry:
    name: str = "jethexa"
    link_lengths: tuple[float, float, float] = (0.045, 0.077, 0.123)
    link_masses: tuple[float, float, float] = (0.04, 0.06, 0.03)
    link_radius: float = 0.008
    foot_radius: float = 0.010
    body_half_size: tuple[float, float, float] = (0.07, 0.13, 0.025)
    body_mass: float = 1.2
    hip_front: tuple[float, float] = (0.065, 0.12)  # |x|, y of legs 1, 2 (rear mirrored)
    hip_middle_x: float = 0.085
    joint_range_deg: tuple[tuple[float, float], ...] = ((-80, 80), (-90, 90), (-165, 10))
    torque_limit: float = 3.4  # N*m, 35 kg*cm bus servo
    armature: float = 5e-3
    kp: float = 500.0
    kd: float = 1.0
    ki: float = 10.0
    friction: float = 1.0
    timestep: float = DEFAULT_TIMESTEP  # the recovery job sets its own too (spec sim.timestep_s)

    def legs(self) -> list[LegGeometry]:
        fx, fy = self.hip_front
        rows = {1: (fx, fy), 3: (self.hip_middle_x, 0.0), 5: (fx, -fy)}
        out = []
        for leg in LEG_IDS:
            side = -1 if leg % 2 else 1
            x, y = rows[leg if leg % 2 else leg - 1]
            out.append(LegGeometry(leg=leg, hip=(side * x, y, 0.0), side=side))
        return out

    def leg(self, leg: int) -> LegGeometry:
        return self.legs()[leg - 1]

    @property
    def total_mass(self) -> float:
        return self.body_mass + 6 * sum(self.link_masses)


JETHEXA = HexapodGeometry()


def leg_frame_quat(side: int) -> np.ndarray:
    """Leg frame: x outward, z up. Right legs use the body axes; left legs turn 180 deg
    about z so that the same joint conventions (and the same IK) serve both sides."""
    if side > 0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.array([0.0, 0.0, 0.0, 1.0])


def leg_name(leg: int) -> str:
    """Leg ``leg``'s name in the leg map (the paper's number as the robot layer names it)."""
    return f"leg{leg}"


def joint_name(leg: int, joint: str) -> str:
    return f"{leg_name(leg)}_{joint}"


def build_spec(geom: HexapodGeometry = JETHEXA) -> mujoco.MjSpec:
    """The intact robot on a flat floor. Damage is applied to the returned spec."""
    spec = new_spec(geom.name, geom.timestep, "pyramidal")

    # Only the floor has contype 1; feet, chassis, coxae and femurs have conaffinity 1, so
    # every robot-floor pair is tested and no link-link pair ever is (the collision phase
    # stays tiny). Chassis, coxa and femur contacts are what the fall test looks for.
    floor = spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
        contype=1, conaffinity=0, friction=[geom.friction, 0.005, 1e-4],
        rgba=[0.82, 0.84, 0.86, 1],
    )
    del floor
    spec.worldbody.add_light(pos=[0, 0, 3], dir=[0, 0, -1])

    L1, L2, L3 = geom.link_lengths
    m1, m2, m3 = geom.link_masses
    r = geom.link_radius

    torso = spec.worldbody.add_body(name="torso", pos=[0, 0, 0.2])
    torso.add_freejoint(name="root")
    torso.add_geom(
        name="chassis", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(geom.body_half_size),
        mass=geom.body_mass, contype=0, conaffinity=1, rgba=[0.15, 0.45, 0.75, 1],
    )
    torso.add_site(name="imu", pos=[0, 0, 0])

    (q1lo, q1hi), (q2lo, q2hi), (q3lo, q3hi) = [
        (math.radians(a), math.radians(b)) for a, b in geom.joint_range_deg
    ]
    for lg in geom.legs():
        n = lg.leg
        coxa = torso.add_body(name=f"leg{n}_coxa", pos=list(lg.hip), quat=list(leg_frame_quat(lg.side)))
        coxa.add_joint(name=joint_name(n, "coxa"), axis=[0, 0, 1], range=[q1lo, q1hi],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        coxa.add_geom(name=f"leg{n}_coxa", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, L1, 0, 0],
                      size=[r, 0, 0], mass=m1, contype=0, conaffinity=1, rgba=[0.3, 0.3, 0.3, 1])
        femur = coxa.add_body(name=f"leg{n}_femur", pos=[L1, 0, 0])
        femur.add_joint(name=joint_name(n, "femur"), axis=[0, -1, 0], range=[q2lo, q2hi],
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        femur.add_geom(name=f"leg{n}_femur", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, L2, 0, 0],
                       size=[r, 0, 0], mass=m2, contype=0, conaffinity=1, rgba=[0.25, 0.25, 0.25, 1])
        tibia = femur.add_body(name=f"leg{n}_tibia", pos=[L2, 0, 0])
        tibia.add_joint(name=joint_name(n, "tibia"), axis=[0, -1, 0], range=[q3lo, q3hi],
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        tibia.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, L3, 0, 0], size=[r * 0.8, 0, 0],
                       mass=m3, contype=0, conaffinity=0, rgba=[0.2, 0.2, 0.2, 1])
        tibia.add_geom(name=f"leg{n}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[L3, 0, 0],
                       size=[geom.foot_radius, 0, 0], mass=0.0, contype=0, conaffinity=1,
                       friction=[geom.friction, 0.005, 1e-4], rgba=[0.9, 0.4, 0.1, 1])
        tibia.add_site(name=f"leg{n}_tip", pos=[L3, 0, 0])

        for jn in JOINT_NAMES:
            add_pid_servo(spec, f"{joint_name(n, jn)}_pid", joint_name(n, jn), geom.kp, geom.kd, geom.torque_limit,
                          ki=geom.ki)

    add_torso_sensors(spec)
    return spec


def leg_map(geom: HexapodGeometry = JETHEXA, stance: dict[int, list[float]] | None = None,
            stance_height: float | None = None):
    """The leg map of build_spec(geom): legs leg1..leg6 (odd left, even right; front to
    back in pairs), joints coxa-femur-tibia, feet the tip sites, forward +y, the PID gains
    and torque limit of the servos; stance joint values per leg number if given."""
    from app.robots.legmap import Foot, Gains, Leg, LegMap

    legs = [Leg(name=leg_name(lg.leg), side="left" if lg.side < 0 else "right", order=(lg.leg - 1) // 2,
                joints=[joint_name(lg.leg, j) for j in JOINT_NAMES], foot=Foot(kind="site", name=f"leg{lg.leg}_tip"),
                stance=None if stance is None else [float(v) for v in stance[lg.leg]])
            for lg in geom.legs()]
    return LegMap(trunk="torso", forward="+y", legs=legs, stance_height=stance_height,
                  gains=Gains(kp=geom.kp, kd=geom.kd, ki=geom.ki, force_limit=geom.torque_limit))


FALL_BODIES = ("torso",) + tuple(f"leg{n}_{j}" for n in LEG_IDS for j in ("coxa", "femur"))


ALL_CONTACTS = "all_contacts"  # the sensor that counts every contact (the fall test's, with the feet's)


def add_fall_sensors(spec: mujoco.MjSpec, merged: bool = True) -> mujoco.MjSpec:
    """The contact sensors the fall test and the feet's report read from the rollout's
    sensordata: ``leg<n>_foot_touch`` on each remaining foot (its contact count, for the time
    the robot stands on fewer than three feet: a walk that rocks on two feet has not fallen),
    and ``all_contacts``, every contact's count. The robot's only colliding geoms are its
    feet and the bodies that must never touch the ground (chassis, coxae, femurs), and they
    collide with the world only, so every contact that is not a foot's is such a body on the
    ground: the fall test reads ``all_contacts`` minus the feet's counts. One sensor in place
    of one per body (``<body>_ground``, as uploaded robots keep, whose shins may touch the
    ground without a fall) is the same test in less time a step, as each contact sensor scans
    every contact (docs/recovery_speed.md). ``merged`` False: one sensor per watched body
    instead (``<body>_ground``), the setting before, kept to measure the change against.
    Added after damage, so lost legs carry none."""
    feet = {f"leg{n}_foot" for n in LEG_IDS}
    for g in spec.geoms:
        body = g.parent.name
        if body != spec.worldbody.name and (g.contype or g.conaffinity) and not (
                g.name in feet or body in FALL_BODIES):
            raise ValueError(f"geom {g.name!r} of body {body!r} can collide but is neither a foot nor a body the fall "
                             "test watches: all_contacts would count it as a fall")
    for n in LEG_IDS:
        if spec.geom(f"leg{n}_foot") is not None:
            spec.add_sensor(name=f"leg{n}_foot_touch", type=mujoco.mjtSensor.mjSENS_CONTACT,
                            objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=f"leg{n}_foot", intprm=[1, 1, 1])
    if not merged:
        for name in FALL_BODIES:
            if spec.body(name) is not None:
                spec.add_sensor(name=f"{name}_ground", type=mujoco.mjtSensor.mjSENS_CONTACT,
                                objtype=mujoco.mjtObj.mjOBJ_BODY, objname=name, intprm=[1, 1, 1])
        return spec
    spec.add_sensor(name=ALL_CONTACTS, type=mujoco.mjtSensor.mjSENS_CONTACT, intprm=[1, 0, 1])
    return spec

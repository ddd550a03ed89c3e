"""Heavy-duty hexapod of paper 002 (Zhang et al. 2024), built procedurally with MjSpec.

Size and mass (Sec. 2.1): 4.7 m long, 5 t: body 4.4 t, legs 0.1 t each. Numbering as the
paper: legs 1-3 on the left (+y) front to rear, legs 4-6 on the right (-y) front to rear;
tripods {1, 3, 5} and {2, 4, 6}; body frame x forward, z up, origin at the body centre.

Leg (Eq. 1-2): the pantograph's three actuated joints become, one to one, a swing hinge
J_theta about the body x axis at the coxa origin B_i, a horizontal slide x = K_x J_x along
x, and a leg-length slide d = K_z J_z + L2 inside the leg plane, which sits L1 beside B_i.
The foot then lies exactly where Eq. 1 puts it; the scale factors K_x = 5, K_z = 4 of the
pantograph only rescale the joint units, so the joints are expressed in foot units
(metres at the foot) and the ranges below are foot ranges:

    x (horizontal) in [-0.8, 0.8] m about the hip   (J_x in [-0.16, 0.16] m at K_x = 5)
    d (leg length) in [1.2, 2.3] m                  (J_z = (d - L2) / K_z)
    theta (swing)  in [-10, 45] deg, positive = foot outward

The paper gives footholds (+-2.39..2.49, +-1.89..1.91, -1.73..-1.78) m (Sec. 5.2); hips at
x = +-1.7, 0 and |y| = 0.75, 0.2 m under the body centre with L1 = 0.3 m put the nominal
foothold at (+-2.4, +-1.9, -1.74) with d = 1.90 m and theta = 27.8 deg. The paper's stated
2.5 m width is the folded leg pose; its footholds span 3.8 m.

Actuation: MuJoCo 4's native ``pid`` actuator on every joint (position control, the
integral term off: a tipping robot winds it up) plus a ``motor`` per joint carrying the
feed-forward torques of the QP force distribution (J^T f). Gains give ~1 cm of leg
compression under a tripod's load (4e6 N/m) and are damped near critically.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.pantograph import LegWorkspace, leg_ik
from app.robots.mjcf import add_pid_servo, add_torso_sensors, describe_legs, new_spec

LEG_IDS = (1, 2, 3, 4, 5, 6)
JOINT_NAMES = ("swing", "horizontal", "vertical")
TRIPODS = ((1, 3, 5), (2, 4, 6))
ROBOT_GROUP = 1  # terrain stays in group 0, so a foothold ray (mj_ray, group 0 only) sees the ground alone


@dataclasses.dataclass(frozen=True)
class HeavyHexapodGeometry:
    name: str = "heavy_hexapod"
    body_half_size: tuple[float, float, float] = (1.9, 0.75, 0.35)
    body_mass: float = 4400.0
    # Sec. 5.2: "the robot's center of gravity [is] in the front of the body frame". A
    # front equipment bay of this mass (part of the 4.4 t) sits 1.2 m ahead of the centre,
    # which puts the CoG 0.11 m forward.
    front_bay_mass: float = 400.0
    front_bay_x: float = 1.2
    leg_masses: tuple[float, float, float] = (40.0, 30.0, 30.0)  # coxa+swing drive, horizontal carriage, shank
    # A load strapped on top of the body (robustness checks: it raises the CoG); 0 = none.
    payload_kg: float = 0.0
    payload_pos: tuple[float, float, float] = (0.0, 0.0, 0.55)
    hip_x: float = 1.7
    hip_y: float = 0.75
    hip_z: float = -0.2
    l1: float = 0.3
    d_range: tuple[float, float] = (1.2, 2.3)
    theta_range_deg: tuple[float, float] = (-10.0, 45.0)
    x_range: tuple[float, float] = (-0.8, 0.8)
    nominal_x: float = 0.7  # front legs +0.7, middle 0, rear -0.7 about the hip
    nominal_foot_yz: tuple[float, float] = (1.9, -1.74)  # |y|, z of the nominal foothold
    foot_radius: float = 0.08
    friction: float = 1.2
    kp: tuple[float, float, float] = (8e6, 2e6, 4e6)  # swing (N m/rad), horizontal, vertical (N/m)
    kv: tuple[float, float, float] = (8e5, 2e5, 3e5)
    force_limit: tuple[float, float, float] = (4e5, 2e5, 2e5)
    armature: tuple[float, float, float] = (200.0, 20.0, 20.0)
    timestep: float = 0.001  # halving it moves the recovered answers < 0.3 deg, < 0.02 s; 2 ms did not (docs/tipping.md)
    impratio: float = 10.0
    noslip_iterations: int = 3  # without it soft contacts creep ~8 mm/s down a 40 deg slope at mu 1.5

    @property
    def total_mass(self) -> float:
        return self.body_mass + self.payload_kg + 6 * sum(self.leg_masses)

    def side(self, leg: int) -> int:
        return 1 if leg <= 3 else -1

    def hip(self, leg: int) -> tuple[float, float, float]:
        row = (leg - 1) % 3  # 0 front, 1 middle, 2 rear
        x = (self.hip_x, 0.0, -self.hip_x)[row]
        return (x, self.side(leg) * self.hip_y, self.hip_z)

    def workspace(self, leg: int) -> LegWorkspace:
        lo, hi = self.theta_range_deg
        return LegWorkspace(leg=leg, hip=self.hip(leg), side=self.side(leg), l1=self.l1, d_range=self.d_range,
                            theta_range=(math.radians(lo), math.radians(hi)), x_range=self.x_range)

    def nominal_foot(self, leg: int) -> np.ndarray:
        """Nominal foothold in the body frame (foot centre)."""
        row = (leg - 1) % 3
        hx, _, _ = self.hip(leg)
        y, z = self.nominal_foot_yz
        return np.array([hx + (self.nominal_x, 0.0, -self.nominal_x)[row], self.side(leg) * y, z])


HEAVY = HeavyHexapodGeometry()


def joint_name(leg: int, joint: str) -> str:
    return f"leg{leg}_{joint}"


def add_robot(spec: mujoco.MjSpec, geom: HeavyHexapodGeometry = HEAVY, pos=(0.0, 0.0, 2.0)) -> None:
    """Add the robot (free body "torso") to ``spec``."""
    torso = spec.worldbody.add_body(name="torso", pos=list(pos))
    torso.add_freejoint(name="root")
    torso.add_geom(name="chassis", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(geom.body_half_size),
                   mass=geom.body_mass - geom.front_bay_mass, contype=1, conaffinity=1, group=ROBOT_GROUP,
                   rgba=[0.85, 0.6, 0.15, 1])
    torso.add_geom(name="front_bay", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.4, 0.6, 0.3],
                   pos=[geom.front_bay_x, 0, 0.05], mass=geom.front_bay_mass, contype=0, conaffinity=0,
                   group=ROBOT_GROUP, rgba=[0.7, 0.45, 0.1, 1])
    if geom.payload_kg > 0:
        torso.add_geom(name="payload", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5, 0.5, 0.2], pos=list(geom.payload_pos),
                       mass=geom.payload_kg, contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.3, 0.5, 0.8, 1])
    torso.add_site(name="imu", pos=[0, 0, 0])
    m_coxa, m_carriage, m_shank = geom.leg_masses
    (tlo, thi) = (math.radians(a) for a in geom.theta_range_deg)
    for leg in LEG_IDS:
        s = geom.side(leg)
        coxa = torso.add_body(name=f"leg{leg}_coxa", pos=list(geom.hip(leg)))
        # Rotation about s*x: positive theta moves the foot outward on both sides (Eq. 1).
        coxa.add_joint(name=joint_name(leg, "swing"), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[s, 0, 0],
                       range=[tlo, thi], limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature[0])
        coxa.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, s * geom.l1, 0], size=[0.12, 0, 0],
                      mass=m_coxa, contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.3, 0.3, 0.3, 1])
        carriage = coxa.add_body(name=f"leg{leg}_carriage", pos=[0, s * geom.l1, 0])
        carriage.add_joint(name=joint_name(leg, "horizontal"), type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0],
                           range=list(geom.x_range), limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature[1])
        carriage.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.25, 0.1, 0.15], mass=m_carriage,
                          contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.35, 0.35, 0.4, 1])
        shank = carriage.add_body(name=f"leg{leg}_shank", pos=[0, 0, 0])
        shank.add_joint(name=joint_name(leg, "vertical"), type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, -1],
                        range=list(geom.d_range), limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature[2])
        # Slide value = leg length d: at d the shank origin (the foot) is d below the carriage.
        shank.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, geom.d_range[0]], size=[0.07, 0, 0],
                       mass=m_shank, contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.2, 0.2, 0.2, 1])
        shank.add_geom(name=f"leg{leg}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0, 0, 0],
                       size=[geom.foot_radius, 0, 0], mass=0.0, contype=1, conaffinity=1, group=ROBOT_GROUP,
                       friction=[geom.friction, 0.005, 1e-4], rgba=[0.9, 0.3, 0.1, 1])
        shank.add_site(name=f"leg{leg}_tip", pos=[0, 0, 0])
        for jn, kp, kv, fl in zip(JOINT_NAMES, geom.kp, geom.kv, geom.force_limit):
            add_pid_servo(spec, f"{joint_name(leg, jn)}_pid", joint_name(leg, jn), kp, kv, fl, ki=0.0)
    for leg in LEG_IDS:
        for jn, fl in zip(JOINT_NAMES, geom.force_limit):
            ff = spec.add_actuator(name=f"{joint_name(leg, jn)}_ff", target=joint_name(leg, jn),
                                   trntype=mujoco.mjtTrn.mjTRN_JOINT)
            ff.set_to_motor()
            ff.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            ff.ctrlrange = [-fl, fl]
    add_torso_sensors(spec)


def base_spec(geom: HeavyHexapodGeometry = HEAVY) -> mujoco.MjSpec:
    spec = new_spec(geom.name, geom.timestep, "elliptic")  # the QP's pyramid is inscribed in this cone
    # Soft friction creeps under a sustained tangential load (a 5 t robot on a 40 deg slope);
    # a high impratio makes it stick, as the paper assumes ("no foot slipping").
    spec.option.impratio = geom.impratio
    spec.option.noslip_iterations = geom.noslip_iterations
    spec.worldbody.add_light(pos=[0, 0, 12], dir=[0, 0, -1])
    return spec


def build_tilt_spec(geom: HeavyHexapodGeometry = HEAVY, platform_half: float = 4.5,
                    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)) -> mujoco.MjSpec:
    """The robot on the paper's tilting platform (Sec. 5.2): a 20 t platform on a hinge
    about ``axis`` through the centre of its top face (the world origin), driven by a stiff
    position servo ("tilt") as the paper's Stewart platform is. A real joint, not a mocap
    body: the contacts then see the platform's velocity instead of a jump every step. A
    floor 8 m below (deeper than the table's corner at 60 deg) catches a robot that falls off."""
    spec = base_spec(geom)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1], pos=[0, 0, -8.0],
                            friction=[geom.friction, 0.005, 1e-4], rgba=[0.5, 0.55, 0.6, 1])
    plat = spec.worldbody.add_body(name="platform", pos=[0, 0, 0])
    plat.add_joint(name="tilt", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(axis), range=[-1.2, 1.2],
                   limited=mujoco.mjtLimited.mjLIMITED_TRUE)
    plat.add_geom(name="platform_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=[platform_half, platform_half, 0.15],
                  pos=[0, 0, -0.15], mass=20000.0, friction=[geom.friction, 0.005, 1e-4], rgba=[0.6, 0.65, 0.7, 1])
    act = spec.add_actuator(name="tilt_servo", target="tilt", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.set_to_position(kp=2e10, kv=1.5e8)
    add_robot(spec, geom, pos=(0.0, 0.0, -geom.nominal_foot_yz[1] + geom.foot_radius + 0.005))
    return spec


def build_cliff_spec(geom: HeavyHexapodGeometry = HEAVY, cliff_x: float = 4.0, side: int = -1, drop: float = 3.0,
                     length: float = 30.0) -> mujoco.MjSpec:
    """Flat ground along +x whose ``side`` half (-1 right, +1 left) ends at ``cliff_x``: a
    unilateral cliff (Sec. 5.1). The floor ``drop`` metres below is the void's bottom."""
    spec = base_spec(geom)
    fr = [geom.friction, 0.005, 1e-4]
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1], pos=[0, 0, -drop],
                            friction=fr, rgba=[0.45, 0.5, 0.55, 1])
    x0 = -8.0
    # The intact half (and a strip under the body's centre line) runs the whole way ...
    spec.worldbody.add_geom(name="ground_full", type=mujoco.mjtGeom.mjGEOM_BOX,
                            size=[(length - x0) / 2, 3.0, 0.25], pos=[(length + x0) / 2, -side * 3.0, -0.25],
                            friction=fr, rgba=[0.6, 0.65, 0.7, 1])
    # ... the other half stops at the cliff edge.
    spec.worldbody.add_geom(name="ground_cliff", type=mujoco.mjtGeom.mjGEOM_BOX,
                            size=[(cliff_x - x0) / 2, 3.0, 0.25], pos=[(cliff_x + x0) / 2, side * 3.0, -0.25],
                            friction=fr, rgba=[0.6, 0.65, 0.7, 1])
    add_robot(spec, geom, pos=(0.0, 0.0, -geom.nominal_foot_yz[1] + geom.foot_radius + 0.005))
    return spec


def scaled_masses(geom: HeavyHexapodGeometry, factor: float) -> HeavyHexapodGeometry:
    """Every link mass times ``factor`` (same shapes, same CoG): a robustness perturbation."""
    return dataclasses.replace(geom, body_mass=geom.body_mass * factor, front_bay_mass=geom.front_bay_mass * factor,
                               leg_masses=tuple(m * factor for m in geom.leg_masses))


def joint_targets(geom: HeavyHexapodGeometry, feet_body: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """(theta, x, d) per leg for body-frame foot points, by the closed-form IK (Eq. 2)."""
    out = {}
    for leg, p in feet_body.items():
        x, d, th = leg_ik(geom.workspace(leg), p)
        out[leg] = np.array([th, x, d])
    return out


def describe(geom: HeavyHexapodGeometry = HEAVY) -> dict:
    """Catalog entry in the shape of ``RobotEntry.describe()`` (for /api/robots)."""
    return describe_legs(
        geom.name, "Heavy-duty 18-DoF hexapod (paper 002): 5 t, 4.7 m, pantograph legs as swing hinge + two slides",
        LEG_IDS, JOINT_NAMES, geom.side, geom.hip) | {
        "nominal_feet_m": {str(l): geom.nominal_foot(l).tolist() for l in LEG_IDS},
        "total_mass_kg": geom.total_mass,
        "parameters": {
            "l1_m": geom.l1, "leg_length_range_m": list(geom.d_range), "swing_range_deg": list(geom.theta_range_deg),
            "horizontal_range_m": list(geom.x_range), "tripods": [list(t) for t in TRIPODS],
            "pid": {"kp": list(geom.kp), "kd": list(geom.kv), "ki": 0.0}, "friction": geom.friction,
        },
    }

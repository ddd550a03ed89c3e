"""SILO-6-like demining hexapod of paper 004 (Estremera, Cobano, Gonzalez de Santos), with MjSpec.

Table 1: body 0.88 x 0.63 x 0.26 m and 28.2 kg; six insect-type 3-DoF legs of 4.3 kg with
links a1 = 0.084 (coxa), a2 = 0.250 (femur), a3 = 0.250 m (tibia); 54 kg in all; stroke
R_x = 0.25 m; stroke pitch P_x = 0.365 m (distance between neighbouring legs' workspaces).

Numbering (papers README, Sec. 5.1): odd legs on the left (+y), even legs on the right (-y);
(1, 2) front, (3, 4) middle, (5, 6) rear; tripod 1 = {1, 4, 5}, tripod 2 = {2, 3, 6}, each
the front and rear leg of one side and the middle leg of the other. Body frame: x forward,
y left, z up, origin at the body's geometric centre (where the paper puts the COG).

Hips sit on the body's sides (|y| = W_B / 2) at x = +P_x, 0, -P_x. The leg frame has x
pointing outward and z up, so the closed-form IK of app.robots.ik serves every leg; the
femur and tibia hinges turn about the leg frame's -y so that a positive angle lifts (knee up,
insect-type).

Leg workspace (Fig. 6 is missing from the copy; derived from Table 1 and documented in
docs/freegait.md): a vertical prism whose horizontal section is a rectangle R_x = 0.25 m
long (the stroke) by R_y = 0.16 m wide centred on the nominal foothold (hip x, +-0.57 m),
and whose height runs from z = -0.40 m to -0.12 m in the body frame. Every point of it is
reachable with the knee up (the far corner at z = -0.40 needs 0.485 m of the 0.50 m
femur + tibia); workspaces of neighbouring legs are P_x - R_x = 0.115 m apart, so legs
cannot cross. The robot stands with its feet H_m = 0.30 m below the body centre.

Actuation: position servos (geared DC motors in the real robot) with joint armature for
the gear trains; gains hold a tripod's share of 54 kg to ~1 cm at the foot.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.ik import leg_fk, leg_ik
from app.robots.mjcf import add_frame_sensors, describe_legs, limit_force, new_spec

LEG_IDS = (1, 2, 3, 4, 5, 6)
JOINT_NAMES = ("coxa", "femur", "tibia")
TRIPODS = ((1, 4, 5), (2, 3, 6))  # (front, centre, rear) of each tripod, Sec. 5.1
ROBOT_GROUP = 1


@dataclasses.dataclass(frozen=True)
class Silo6Geometry:
    name: str = "silo6"
    body_size: tuple[float, float, float] = (0.88, 0.63, 0.26)  # L_B, W_B, H_B
    body_mass: float = 28.2
    link_lengths: tuple[float, float, float] = (0.084, 0.250, 0.250)
    link_masses: tuple[float, float, float] = (1.0, 1.8, 1.5)  # 4.3 kg per leg (Table 1)
    stroke_pitch: float = 0.365  # P_x
    stroke: float = 0.25  # R_x
    stroke_width: float = 0.16  # R_y (not in Table 1; see the module docstring)
    foot_lateral: float = 0.57  # |y| of the workspace centre
    z_range: tuple[float, float] = (-0.40, -0.12)  # workspace height in the body frame
    stand_height: float = 0.30  # H_m: feet below the body centre
    foot_radius: float = 0.02
    link_radius: float = 0.025
    joint_range_deg: tuple[tuple[float, float], ...] = ((-70, 70), (-60, 100), (-170, -5))
    kp: float = 3000.0  # N m / rad
    kv: float = 80.0
    torque_limit: float = 250.0
    armature: float = 0.2
    friction: float = 0.9
    timestep: float = 0.002
    transfer_foot_speed: float = 0.14  # Table 1, m/s
    max_speed: float = 0.05  # Table 1, m/s

    @property
    def total_mass(self) -> float:
        return self.body_mass + 6 * sum(self.link_masses)

    def side(self, leg: int) -> int:
        return 1 if leg % 2 else -1

    def hip(self, leg: int) -> np.ndarray:
        row = (leg - 1) // 2
        return np.array([(self.stroke_pitch, 0.0, -self.stroke_pitch)[row], self.side(leg) * self.body_size[1] / 2, 0.0])

    def workspace_centre(self, leg: int) -> np.ndarray:
        """Centre of the leg's horizontal workspace rectangle (body frame, xy)."""
        return np.array([self.hip(leg)[0], self.side(leg) * self.foot_lateral])

    def workspace_rect(self, leg: int) -> np.ndarray:
        """(xmin, xmax, ymin, ymax) of the horizontal workspace."""
        cx, cy = self.workspace_centre(leg)
        hx, hy = self.stroke / 2, self.stroke_width / 2
        return np.array([cx - hx, cx + hx, cy - hy, cy + hy])

    def workspaces(self) -> np.ndarray:
        return np.stack([self.workspace_rect(l) for l in LEG_IDS])  # (6, 4)

    def nominal_feet(self) -> np.ndarray:
        """(6, 3) nominal footholds in the body frame."""
        return np.array([[*self.workspace_centre(l), -self.stand_height] for l in LEG_IDS])


SILO6 = Silo6Geometry()


def joint_name(leg: int, joint: str) -> str:
    return f"leg{leg}_{joint}"


def _leg_quat(side: int) -> list[float]:
    # Leg frame x outward: +y for left legs (turn +90 deg about z), -y for right legs.
    a = math.pi / 4 * side
    return [math.cos(a), 0.0, 0.0, math.sin(a)]


def _leg_rot(side: int) -> np.ndarray:
    """Rotation leg frame -> body frame."""
    return np.array([[0.0, -side, 0.0], [side, 0.0, 0.0], [0.0, 0.0, 1.0]])


def add_robot(spec: mujoco.MjSpec, geom: Silo6Geometry = SILO6, pos=(0.0, 0.0, 0.5)) -> None:
    """Add the robot (free body "torso") with its actuators and sensors to ``spec``."""
    a1, a2, a3 = geom.link_lengths
    m1, m2, m3 = geom.link_masses
    r = geom.link_radius
    torso = spec.worldbody.add_body(name="torso", pos=list(pos))
    torso.add_freejoint(name="root")
    half = [s / 2 for s in geom.body_size]
    torso.add_geom(name="chassis", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, mass=geom.body_mass,
                   contype=1, conaffinity=0, group=ROBOT_GROUP, rgba=[0.85, 0.75, 0.2, 1])
    torso.add_site(name="imu", pos=[0, 0, 0])
    (c_lo, c_hi), (f_lo, f_hi), (t_lo, t_hi) = [(math.radians(a), math.radians(b)) for a, b in geom.joint_range_deg]
    for leg in LEG_IDS:
        s = geom.side(leg)
        coxa = torso.add_body(name=f"leg{leg}_coxa", pos=geom.hip(leg).tolist(), quat=_leg_quat(s))
        coxa.add_joint(name=joint_name(leg, "coxa"), axis=[0, 0, 1], range=[c_lo, c_hi],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        coxa.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, a1, 0, 0], size=[r, 0, 0], mass=m1,
                      contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.3, 0.3, 0.3, 1])
        femur = coxa.add_body(name=f"leg{leg}_femur", pos=[a1, 0, 0])
        femur.add_joint(name=joint_name(leg, "femur"), axis=[0, -1, 0], range=[f_lo, f_hi],
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        femur.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, a2, 0, 0], size=[r, 0, 0], mass=m2,
                       contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.25, 0.25, 0.25, 1])
        tibia = femur.add_body(name=f"leg{leg}_tibia", pos=[a2, 0, 0])
        tibia.add_joint(name=joint_name(leg, "tibia"), axis=[0, -1, 0], range=[t_lo, t_hi],
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=geom.armature)
        tibia.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, a3, 0, 0], size=[r * 0.8, 0, 0],
                       mass=m3, contype=0, conaffinity=0, group=ROBOT_GROUP, rgba=[0.2, 0.2, 0.2, 1])
        tibia.add_geom(name=f"leg{leg}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[a3, 0, 0],
                       size=[geom.foot_radius, 0, 0], mass=0.0, contype=1, conaffinity=0, group=ROBOT_GROUP,
                       friction=[geom.friction, 0.005, 1e-4], rgba=[0.9, 0.35, 0.1, 1])
        tibia.add_site(name=f"leg{leg}_tip", pos=[a3, 0, 0])
        # The touch sensor's volume: a sphere just larger than the foot (the foot switch).
        tibia.add_site(name=f"leg{leg}_touch", pos=[a3, 0, 0], size=[geom.foot_radius * 1.6, 0, 0],
                       type=mujoco.mjtGeom.mjGEOM_SPHERE, group=4)
        for jn in JOINT_NAMES:
            act = spec.add_actuator(name=f"{joint_name(leg, jn)}_pos", target=joint_name(leg, jn),
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_position(kp=geom.kp, kv=geom.kv)
            limit_force(act, geom.torque_limit)
    # Simulated sensors, in this order (the controller reads nothing else):
    # 18 joint encoders, 6 foot switches, body quaternion (inclinometers), body position (DGPS).
    for leg in LEG_IDS:
        for jn in JOINT_NAMES:
            spec.add_sensor(name=f"{joint_name(leg, jn)}_enc", type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                            objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=joint_name(leg, jn))
    for leg in LEG_IDS:
        spec.add_sensor(name=f"leg{leg}_switch", type=mujoco.mjtSensor.mjSENS_TOUCH,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"leg{leg}_touch")
    add_frame_sensors(spec, (("torso_quat", "quat"), ("torso_pos", "pos")), mujoco.mjtObj.mjOBJ_BODY, "torso")
    for leg in LEG_IDS:
        spec.add_sensor(name=f"leg{leg}_tip_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"leg{leg}_tip")


SENSOR_SLICES = {"joints": slice(0, 18), "touch": slice(18, 24), "quat": slice(24, 28), "pos": slice(28, 31),
                 "tips": slice(31, 49)}  # tips: ground truth for the records only, never read by the controller


def base_spec(geom: Silo6Geometry = SILO6) -> mujoco.MjSpec:
    spec = new_spec(geom.name, geom.timestep, "pyramidal")
    spec.worldbody.add_light(pos=[0, 0, 6], dir=[0, 0, -1])
    return spec


def build_flat_spec(geom: Silo6Geometry = SILO6) -> mujoco.MjSpec:
    """The robot standing on a flat floor (tests, the catalog's robot.xml)."""
    spec = base_spec(geom)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], contype=0,
                            conaffinity=1, friction=[geom.friction, 0.005, 1e-4], rgba=[0.55, 0.5, 0.4, 1])
    add_robot(spec, geom, pos=(0.0, 0.0, geom.stand_height + geom.foot_radius))
    return spec


def leg_ik_body(geom: Silo6Geometry, feet: np.ndarray) -> np.ndarray:
    """Joint angles (..., 6, 3) for foot centres (..., 6, 3) in the body frame."""
    hips = np.stack([geom.hip(l) for l in LEG_IDS])
    rots = np.stack([_leg_rot(geom.side(l)) for l in LEG_IDS])  # leg -> body
    local = np.einsum("lji,...lj->...li", rots, feet - hips)  # body -> leg: R^T (p - hip)
    return leg_ik(local, geom.link_lengths)


def leg_fk_body(geom: Silo6Geometry, q: np.ndarray) -> np.ndarray:
    """Foot centres (..., 6, 3) in the body frame for joint angles (..., 6, 3)."""
    hips = np.stack([geom.hip(l) for l in LEG_IDS])
    rots = np.stack([_leg_rot(geom.side(l)) for l in LEG_IDS])
    local = leg_fk(q, geom.link_lengths)
    return np.einsum("lij,...lj->...li", rots, local) + hips


def describe(geom: Silo6Geometry = SILO6) -> dict:
    return describe_legs(
        geom.name, "SILO-6-like demining hexapod (paper 004): 54 kg, insect-type 3-DoF legs, position servos",
        LEG_IDS, JOINT_NAMES, geom.side, geom.hip) | {
        "link_lengths_m": list(geom.link_lengths),
        "total_mass_kg": round(geom.total_mass, 4),
        "parameters": {
            "body_size_m": list(geom.body_size), "stroke_m": geom.stroke, "stroke_pitch_m": geom.stroke_pitch,
            "stroke_width_m": geom.stroke_width, "workspace_z_m": list(geom.z_range),
            "stand_height_m": geom.stand_height, "tripods": [list(t) for t in TRIPODS],
            "workspaces_m": {str(l): geom.workspace_rect(l).tolist() for l in LEG_IDS},
        },
    }

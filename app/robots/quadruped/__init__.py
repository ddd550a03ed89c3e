"""quadruped25: the 25 kg quadruped of paper 003 (Table 1), built procedurally with MjSpec.

Frame: x forward, y left, z up; the trunk's frame origin is its centre of mass, so the free
joint's rotational DOFs act about the CoM (Eq. 5 takes moments there). Legs in the paper's
order FR, HR, FL, HL; each has hip abduction (about x), thigh and knee (about y): 12 actuated
joints, 18 DoF. At zero angles the leg hangs straight down: the hip link goes sideways
(``side`` * l_hip), the thigh and calf straight down.

Table 1: trunk 25 kg, [Ix, Iy, Iz] = [0.35, 2.1, 2.1] kg m^2, 0.6 x 0.25 x 0.2 m; links
hip/thigh/calf [0.06, 0.33, 0.33] m, [0.06, 0.16, 0.16] kg, inertias about the joint
[0.01; 0.02; 0.02] and [0.03; 0.09; 0.09] kg m^2 (axial component first). The papers README
notes those inertias are 10-1000x what slender links of that mass and length have; they are
the paper's robot, so ``inertia="table1"`` is the default and ``"rod"`` (a slender rod of
radius ``link_radius``: m l^2/3 transverse, m r^2/2 axial, about the joint) is the derived
alternative.

Scaling rule when the GA changes a link length l (reference l0 of Table 1): the link keeps
its linear density, so m = m0 l/l0; the inertia about the joint scales as m l^2 for the
transverse axes, (l/l0)^3, and as m for the axial one, (l/l0). The CoM inertia (what MuJoCo
takes) is the joint inertia less m (l/2)^2 transverse (parallel axes), which stays positive
under this rule because it scales by (l/l0)^3 as a whole.

The hips sit at the trunk's corners (+-L/2, +-W/2) at the CoM height. Feet are spheres of
radius ``foot_radius`` whose centre is the leg tip; the physics floor is put at
z = -foot_radius so a tip at z = 0 touches it, and heights are tip heights throughout.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.mjcf import describe_legs, new_spec

LEGS = ("FR", "HR", "FL", "HL")
JOINTS = ("hip", "thigh", "knee")


@dataclasses.dataclass(frozen=True)
class QuadrupedGeometry:
    name: str = "quadruped25"
    trunk_mass: float = 25.0
    trunk_inertia: tuple[float, float, float] = (0.35, 2.1, 2.1)
    trunk_size: tuple[float, float, float] = (0.6, 0.25, 0.2)  # L, W, H
    links: tuple[float, float, float] = (0.06, 0.33, 0.33)  # hip, thigh, calf
    ref_links: tuple[float, float, float] = (0.06, 0.33, 0.33)
    link_masses: tuple[float, float, float] = (0.06, 0.16, 0.16)  # at ref_links
    inertia: str = "table1"  # or "rod"
    hip_inertia: tuple[float, float] = (0.01, 0.02)  # axial, transverse, about the joint (Table 1)
    link_inertia: tuple[float, float] = (0.03, 0.09)  # thigh = calf
    link_radius: float = 0.02
    foot_radius: float = 0.02
    friction: float = 0.6
    timestep: float = 0.001
    joint_damping: float = 0.0
    armature: float = 0.0
    torque_limit: float = 200.0

    def __post_init__(self):
        if self.inertia not in ("table1", "rod"):
            raise ValueError("inertia must be 'table1' or 'rod'")

    def side(self, leg: str) -> int:
        return 1 if leg.endswith("L") else -1

    def hip(self, leg: str) -> np.ndarray:
        L, W, _ = self.trunk_size
        return np.array([L / 2 if leg.startswith("F") else -L / 2, self.side(leg) * W / 2, 0.0])

    def masses(self) -> np.ndarray:
        return np.asarray(self.link_masses) * np.asarray(self.links) / np.asarray(self.ref_links)

    @property
    def leg_mass(self) -> float:
        return float(self.masses().sum())

    @property
    def total_mass(self) -> float:
        return self.trunk_mass + 4 * self.leg_mass

    def joint_inertias(self) -> np.ndarray:
        """(3, 2): axial and transverse inertia about the joint per link (hip, thigh, calf)."""
        lengths, ref = np.asarray(self.links), np.asarray(self.ref_links)
        m = self.masses()
        if self.inertia == "rod":
            return np.stack([0.5 * m * self.link_radius**2, m * lengths**2 / 3.0], axis=1)
        table = np.array([self.hip_inertia, self.link_inertia, self.link_inertia])
        s = lengths / ref
        return np.stack([table[:, 0] * s, table[:, 1] * s**3], axis=1)

    def com_inertias(self) -> np.ndarray:
        """(3, 2): axial and transverse inertia about each link's CoM (parallel axes)."""
        j = self.joint_inertias()
        m, lengths = self.masses(), np.asarray(self.links)
        return np.stack([j[:, 0], j[:, 1] - m * (lengths / 2) ** 2], axis=1)


QUADRUPED25 = QuadrupedGeometry()


def joint_name(leg: str, joint: str) -> str:
    return f"{leg}_{joint}"


def add_robot(spec: mujoco.MjSpec, geom: QuadrupedGeometry = QUADRUPED25, pos=(0.0, 0.0, 0.5)) -> None:
    L, W, H = geom.trunk_size
    trunk = spec.worldbody.add_body(name="trunk", pos=list(pos))
    trunk.add_freejoint(name="root")
    trunk.mass = geom.trunk_mass
    trunk.ipos = [0, 0, 0]
    trunk.inertia = list(geom.trunk_inertia)
    trunk.explicitinertial = True
    trunk.add_geom(name="trunk", type=mujoco.mjtGeom.mjGEOM_BOX, size=[L / 2, W / 2, H / 2], mass=0.0,
                   contype=1, conaffinity=1, rgba=[0.2, 0.45, 0.7, 1])
    trunk.add_site(name="imu", pos=[0, 0, 0])
    l_hip, l_thigh, l_calf = geom.links
    m_hip, m_thigh, m_calf = geom.masses()
    (a_hip, t_hip), (a_thigh, t_thigh), (a_calf, t_calf) = geom.com_inertias()
    r = geom.link_radius
    for leg in LEGS:
        s = geom.side(leg)
        hip = trunk.add_body(name=f"{leg}_hip", pos=list(geom.hip(leg)))
        hip.add_joint(name=joint_name(leg, "hip"), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0],
                      range=[-0.8, 0.8], limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=geom.joint_damping,
                      armature=geom.armature)
        # The hip link's axis is lateral (y): axial inertia on y.
        hip.mass, hip.ipos, hip.inertia = m_hip, [0, s * l_hip / 2, 0], [t_hip, a_hip, t_hip]
        hip.explicitinertial = True
        hip.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, s * l_hip, 0], size=[r, 0, 0],
                     mass=0.0, contype=0, conaffinity=0, rgba=[0.3, 0.3, 0.3, 1])
        thigh = hip.add_body(name=f"{leg}_thigh", pos=[0, s * l_hip, 0])
        thigh.add_joint(name=joint_name(leg, "thigh"), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                        range=[-2.5, 2.5], limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=geom.joint_damping,
                        armature=geom.armature)
        thigh.mass, thigh.ipos, thigh.inertia = m_thigh, [0, 0, -l_thigh / 2], [t_thigh, t_thigh, a_thigh]
        thigh.explicitinertial = True
        thigh.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -l_thigh], size=[r, 0, 0],
                       mass=0.0, contype=0, conaffinity=0, rgba=[0.35, 0.35, 0.4, 1])
        calf = thigh.add_body(name=f"{leg}_calf", pos=[0, 0, -l_thigh])
        calf.add_joint(name=joint_name(leg, "knee"), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                       range=[-2.9, 2.9], limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=geom.joint_damping,
                       armature=geom.armature)
        calf.mass, calf.ipos, calf.inertia = m_calf, [0, 0, -l_calf / 2], [t_calf, t_calf, a_calf]
        calf.explicitinertial = True
        calf.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -l_calf], size=[0.8 * r, 0, 0],
                      mass=0.0, contype=0, conaffinity=0, rgba=[0.2, 0.2, 0.2, 1])
        calf.add_geom(name=f"{leg}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0, 0, -l_calf],
                      size=[geom.foot_radius, 0, 0], mass=0.0, contype=1, conaffinity=1,
                      friction=[geom.friction, 0.005, 1e-4], rgba=[0.9, 0.3, 0.1, 1])
        calf.add_site(name=f"{leg}_tip", pos=[0, 0, -l_calf])
    for leg in LEGS:
        for jn in JOINTS:
            act = spec.add_actuator(name=joint_name(leg, jn), target=joint_name(leg, jn),
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_motor()
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = [-geom.torque_limit, geom.torque_limit]


def build_spec(geom: QuadrupedGeometry = QUADRUPED25, floor: bool = True, height: float = 0.5) -> mujoco.MjSpec:
    spec = new_spec(geom.name, geom.timestep, "elliptic")  # Eq. 6 is the circular cone
    spec.worldbody.add_light(pos=[0, 0, 4], dir=[0, 0, -1])
    if floor:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1],
                                pos=[0, 0, -geom.foot_radius], friction=[geom.friction, 0.005, 1e-4],
                                rgba=[0.55, 0.6, 0.65, 1])
    add_robot(spec, geom, pos=(0.0, 0.0, height))
    return spec


def build_model(geom: QuadrupedGeometry = QUADRUPED25, floor: bool = True) -> mujoco.MjModel:
    return build_spec(geom, floor=floor).compile()


def qpos_index(model: mujoco.MjModel) -> np.ndarray:
    """qpos addresses of the 12 leg joints in LEGS x JOINTS order."""
    return np.array([model.jnt_qposadr[model.joint(joint_name(l, j)).id] for l in LEGS for j in JOINTS])


def dof_index(model: mujoco.MjModel) -> np.ndarray:
    return np.array([model.jnt_dofadr[model.joint(joint_name(l, j)).id] for l in LEGS for j in JOINTS])


def describe(geom: QuadrupedGeometry = QUADRUPED25) -> dict:
    return describe_legs(
        geom.name, "25 kg quadruped of paper 003 (Table 1): 18 DoF, hip abduction + thigh + knee per leg",
        LEGS, JOINTS, geom.side, geom.hip) | {
        "total_mass_kg": geom.total_mass,
        "parameters": {"links_m": list(geom.links), "link_masses_kg": geom.masses().tolist(),
                       "trunk_inertia_kg_m2": list(geom.trunk_inertia), "inertia": geom.inertia,
                       "friction": geom.friction},
    }


def leg_ik(p: np.ndarray, links, side) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form IK of one leg for tip points ``p`` (..., 3) relative to the hip (trunk
    axes). ``side`` broadcasts against p[..., 0]. Returns joint angles (..., 3) and a
    reachability mask (...,). Knee bends with q_knee <= 0 (the knee points forward)."""
    l0, l1, l2 = links
    p = np.asarray(p, dtype=float)
    py, pz = p[..., 1], p[..., 2]
    ryz2 = py**2 + pz**2
    zl = -np.sqrt(np.maximum(ryz2 - l0**2, 0.0))
    q0 = np.arctan2(pz, py) - np.arctan2(zl, side * l0)
    q0 = (q0 + math.pi) % (2 * math.pi) - math.pi
    xl = p[..., 0]
    d2 = xl**2 + zl**2
    c2 = (d2 - l1**2 - l2**2) / (2 * l1 * l2)
    ok = (ryz2 > l0**2) & (c2 > -1.0) & (c2 < 1.0)
    q2 = -np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(-xl, -zl) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    return np.stack([q0, q1, q2], axis=-1), ok


def leg_fk(q: np.ndarray, links, side) -> np.ndarray:
    """Tip position relative to the hip for joint angles q (..., 3); inverse of leg_ik."""
    l0, l1, l2 = links
    q0, q1, q2 = q[..., 0], q[..., 1], q[..., 2]
    xl = -l1 * np.sin(q1) - l2 * np.sin(q1 + q2)
    zl = -l1 * np.cos(q1) - l2 * np.cos(q1 + q2)
    yl = side * l0 * np.ones_like(xl)
    c, s = np.cos(q0), np.sin(q0)
    return np.stack([xl, c * yl - s * zl, s * yl + c * zl], axis=-1)

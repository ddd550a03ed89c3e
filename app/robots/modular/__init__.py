"""Chain-type modular robots of cube modules (paper 001, Sec. V, Fig. 3), built with MjSpec.

A module is a cube of 1 map unit (mu; 1 mu = ``MU`` metres) made of two halves joined by a
1-DoF hinge through the cube's centre, like a CoSMO module. Modules sit on a planar grid
(one cell each); module 0 is the *pivot*, whose pose the planner tracks. Every other module
hangs rigidly off one half of a neighbouring module (its parent), so the robot is a tree
of bodies with one hinge per module and one free joint at the pivot's inner half.

Each module has a long axis ``d`` (the direction from its inner half to its outer half,
pointing away from the pivot) and a hinge type:
  - ``"z"``: the hinge axis is vertical; the outer half yaws (lateral bending, a spine);
  - ``"h"``: the hinge axis is horizontal and perpendicular to ``d``; the outer half pitches
    up and down (lifting, a leg).

Shapes (grid cells (x, y) in mu, +x is the robot's forward direction; ``failures`` are the
two modules that are stuck in experiments E1/C1 (first) and E2/C2 (both), the arrows of
Fig. 3, which the copy of the paper lacks; we chose the ones that most plausibly matter:
a leg or a spine joint of the walking shapes):

  lizard    (7)  spine (-1,0) (0,0) (1,0) with yaw hinges; legs (+-1,+-1) pitching.
                  failures: 3 (front-left leg), 6 (rear-right leg)
                     5 . 3
                     2 0 1      -> +x
                     6 . 4
  quadropod (9)  centre (0,0); four 2-module legs along +-x, +-y: a yawing hip module then a
                  pitching knee module. failures: 2 (front knee), 6 (left knee)
                         6
                         5
                     4 3 0 1 2
                         7
                         8
  tshape    (5)  bar (-1,0) (0,0) (1,0) and a stem (0,-1) (0,-2).  failures: 1, 4
  lshape    (5)  (0,0) (1,0) (2,0) and (0,1) (0,2).                   failures: 2, 4
  hshape    (7)  bars x=-1 and x=1 (y=-1..1) joined through (0,0).    failures: 1, 5

Stuck modules ("one of typical failures of modules is the inability to control the hinge",
Sec. V-A) have their hinge locked at zero: the joint is not created, the halves are one
rigid body, and the module has no actuator and no CPG parameters.

Physics: 0.1 m modules of 0.3 kg (0.15 kg per half), hinge range +-90 deg, a position
servo per hinge (MuJoCo's native ``pid`` actuator, P and D only: the paper's "PD
controller"), 2 N*m torque limit, rotor armature; only the robot-floor pairs collide.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.mjcf import add_frame_sensors, add_pid_servo, new_spec

MU = 0.1  # metres per map unit: a module is a 10 cm cube


@dataclasses.dataclass(frozen=True)
class Module:
    cell: tuple[int, int]  # grid cell of the module centre (mu), pivot at (0, 0)
    d: tuple[int, int]  # long axis: inner half -> outer half, away from the pivot
    hinge: str  # "z" (yaw) or "h" (pitch)
    parent: int  # index of the parent module (-1 for the pivot)
    parent_half: str = "b"  # which half of the parent carries it ("a" inner, "b" outer)


@dataclasses.dataclass(frozen=True)
class Shape:
    name: str
    description: str
    modules: tuple[Module, ...]
    failures: tuple[int, int]  # modules stuck in the 1- and 2-failure experiments

    @property
    def m(self) -> int:
        return len(self.modules)

    def radius_mu(self) -> float:
        """Radius of the footprint around the pivot centre (corner of the farthest cell)."""
        c = np.array([mod.cell for mod in self.modules], dtype=float)
        return float(np.max(np.hypot(np.abs(c[:, 0]) + 0.5, np.abs(c[:, 1]) + 0.5)))

    def describe(self) -> dict:
        return {"name": self.name, "description": self.description, "modules": self.m,
                "cells": [list(mod.cell) for mod in self.modules],
                "hinges": [mod.hinge for mod in self.modules],
                "parents": [mod.parent for mod in self.modules],
                "failures": list(self.failures), "radius_mu": self.radius_mu(), "module_size_m": MU}


def _m(cell, d, hinge, parent, half="b"):
    return Module(cell=cell, d=d, hinge=hinge, parent=parent, parent_half=half)


SHAPES: dict[str, Shape] = {
    "lizard": Shape("lizard", "spine of three yawing modules with four pitching legs", (
        _m((0, 0), (1, 0), "z", -1),
        _m((1, 0), (1, 0), "z", 0, "b"),
        _m((-1, 0), (-1, 0), "z", 0, "a"),
        _m((1, 1), (0, 1), "h", 1, "b"),
        _m((1, -1), (0, -1), "h", 1, "b"),
        _m((-1, 1), (0, 1), "h", 2, "b"),
        _m((-1, -1), (0, -1), "h", 2, "b"),
    ), failures=(3, 6)),
    "quadropod": Shape("quadropod", "centre module with four legs of a yawing hip and a pitching knee", (
        _m((0, 0), (1, 0), "h", -1),
        _m((1, 0), (1, 0), "z", 0, "b"),
        _m((2, 0), (1, 0), "h", 1, "b"),
        _m((-1, 0), (-1, 0), "z", 0, "a"),
        _m((-2, 0), (-1, 0), "h", 3, "b"),
        _m((0, 1), (0, 1), "z", 0, "a"),
        _m((0, 2), (0, 1), "h", 5, "b"),
        _m((0, -1), (0, -1), "z", 0, "a"),
        _m((0, -2), (0, -1), "h", 7, "b"),
    ), failures=(2, 6)),
    "tshape": Shape("tshape", "T: a bar of three with a stem of two", (
        _m((0, 0), (1, 0), "z", -1),
        _m((1, 0), (1, 0), "h", 0, "b"),
        _m((-1, 0), (-1, 0), "h", 0, "a"),
        _m((0, -1), (0, -1), "z", 0, "a"),
        _m((0, -2), (0, -1), "h", 3, "b"),
    ), failures=(1, 4)),
    "lshape": Shape("lshape", "L: a bar of three with a foot of two", (
        _m((0, 0), (1, 0), "z", -1),
        _m((1, 0), (1, 0), "h", 0, "b"),
        _m((2, 0), (1, 0), "z", 1, "b"),
        _m((0, 1), (0, 1), "h", 0, "a"),
        _m((0, 2), (0, 1), "h", 3, "b"),
    ), failures=(2, 4)),
    "hshape": Shape("hshape", "H: two bars of three joined through a centre module", (
        _m((0, 0), (1, 0), "z", -1),
        _m((1, 0), (1, 0), "h", 0, "b"),
        _m((1, 1), (0, 1), "h", 1, "b"),
        _m((1, -1), (0, -1), "h", 1, "b"),
        _m((-1, 0), (-1, 0), "h", 0, "a"),
        _m((-1, 1), (0, 1), "h", 4, "b"),
        _m((-1, -1), (0, -1), "h", 4, "b"),
    ), failures=(1, 5)),
}


@dataclasses.dataclass(frozen=True)
class ModulePhysics:
    half_mass: float = 0.15
    joint_range_deg: float = 90.0
    kp: float = 6.0
    kd: float = 0.15
    torque_limit: float = 2.0
    armature: float = 2e-3
    friction: float = 0.9
    timestep: float = 0.01
    # Newton with a loose budget: 20 iterations / 1e-6 tolerance changed 30 s displacements by
    # a few percent against 100 / 1e-8 at 1.3-1.5x the speed (measured, Lizard and Quadropod).
    iterations: int = 20
    ls_iterations: int = 10
    tolerance: float = 1e-6


PHYSICS = ModulePhysics()


def get_shape(name: str) -> Shape:
    try:
        return SHAPES[name]
    except KeyError:
        raise KeyError(f"unknown modular robot {name!r}; known: {sorted(SHAPES)}") from None


def functional_modules(shape: Shape, stuck: tuple[int, ...] | list[int]) -> list[int]:
    return [i for i in range(shape.m) if i not in set(stuck)]


@dataclasses.dataclass(frozen=True)
class Terrain:
    """Physical terrain: extra static boxes (centre and half sizes in mu) on the floor."""

    boxes: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = ()


def build_spec(shape: Shape, stuck: tuple[int, ...] = (), terrain: Terrain = Terrain(),
               physics: ModulePhysics = PHYSICS) -> mujoco.MjSpec:
    """The robot standing at the origin with its pivot centre at (0, 0, 0.5 mu), heading +x."""
    for s in stuck:
        if not 0 <= s < shape.m:
            raise ValueError(f"stuck module {s} does not exist (modules 0..{shape.m - 1})")
    # Elliptic friction cones are isotropic: a pyramidal cone's edges follow the world axes,
    # so the same gait started at another heading would move differently, and cached gait
    # displacements could not be turned with the robot.
    spec = new_spec(f"modular_{shape.name}", physics.timestep, "elliptic")
    spec.option.iterations = physics.iterations
    spec.option.ls_iterations = physics.ls_iterations
    spec.option.tolerance = physics.tolerance
    fr = [physics.friction, 0.005, 1e-4]
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            contype=1, conaffinity=0, friction=fr, rgba=[0.82, 0.84, 0.86, 1])
    for i, (c, h) in enumerate(terrain.boxes):
        spec.worldbody.add_geom(name=f"terrain{i}", type=mujoco.mjtGeom.mjGEOM_BOX,
                                pos=[v * MU for v in c], size=[v * MU for v in h],
                                contype=1, conaffinity=0, friction=fr, rgba=[0.6, 0.55, 0.5, 1])
    spec.worldbody.add_light(pos=[0, 0, 4], dir=[0, 0, -1])

    s = MU
    rng = math.radians(physics.joint_range_deg)
    # Body frames are axis-aligned with the world at rest; each half is a box of
    # 0.5 x 1 x 1 mu along the module's long axis.
    half_size = {True: [0.25 * s, 0.5 * s, 0.5 * s], False: [0.5 * s, 0.25 * s, 0.5 * s]}
    bodies: dict[tuple[int, str], tuple] = {}  # (module, half) -> (body, world position of its frame)
    for i, mod in enumerate(shape.modules):
        d = np.array([mod.d[0], mod.d[1], 0.0])
        centre = np.array([mod.cell[0] * s, mod.cell[1] * s, 0.5 * s])
        inner_c, outer_c = centre - 0.25 * s * d, centre + 0.25 * s * d
        along_x = mod.d[1] == 0
        colour = [0.85, 0.25, 0.2, 1] if i in stuck else ([0.95, 0.75, 0.1, 1] if i == 0 else [0.2, 0.5, 0.8, 1])
        if mod.parent < 0:
            inner = spec.worldbody.add_body(name=f"m{i}a", pos=list(inner_c))
            inner.add_freejoint(name="root")
        else:
            pbody, ppos = bodies[(mod.parent, mod.parent_half)]
            inner = pbody.add_body(name=f"m{i}a", pos=list(inner_c - ppos))
        inner.add_geom(name=f"m{i}a", type=mujoco.mjtGeom.mjGEOM_BOX, size=half_size[along_x],
                       mass=physics.half_mass, contype=0, conaffinity=1, friction=fr, rgba=colour)
        outer = inner.add_body(name=f"m{i}b", pos=list(outer_c - inner_c))
        if i not in stuck:
            axis = [0.0, 0.0, 1.0] if mod.hinge == "z" else [-d[1], d[0], 0.0]
            outer.add_joint(name=f"hinge{i}", axis=axis, pos=list(-0.25 * s * d), range=[-rng, rng],
                            limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=physics.armature,
                            damping=0.0)
        outer.add_geom(name=f"m{i}b", type=mujoco.mjtGeom.mjGEOM_BOX, size=[v * 0.98 for v in half_size[along_x]],
                       mass=physics.half_mass, contype=0, conaffinity=1, friction=fr,
                       rgba=[c * 0.8 for c in colour[:3]] + [1])
        bodies[(i, "a")] = (inner, inner_c)
        bodies[(i, "b")] = (outer, outer_c)
    bodies[(0, "a")][0].add_site(name="pivot", pos=list(0.25 * s * np.array([1.0, 0.0, 0.0])))

    for i in range(shape.m):
        if i in stuck:
            continue
        add_pid_servo(spec, f"hinge{i}_pd", f"hinge{i}", physics.kp, physics.kd, physics.torque_limit)

    add_frame_sensors(spec, (("pivot_pos", "pos"), ("pivot_quat", "quat")), mujoco.mjtObj.mjOBJ_SITE, "pivot")
    return spec


def build_model(shape: Shape, stuck: tuple[int, ...] = (), terrain: Terrain = Terrain(),
                physics: ModulePhysics = PHYSICS) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    spec = build_spec(shape, tuple(stuck), terrain, physics)
    return spec, spec.compile()

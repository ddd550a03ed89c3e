"""Legged robots built with MjSpec for the tests: layouts, joint axes, link lengths and leg
counts that differ from the JetHexa's, so that detection and IK are shown to work on
robots nobody wrote the code for. Plus the third-party models shipped in wheels."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import mujoco
import numpy as np


@dataclasses.dataclass(frozen=True)
class Layout:
    name: str
    pairs: int  # legs per side
    spacing: float  # hips' distance front to back
    half_width: float  # hips' distance from the centre line
    # joints from the body out: (axis in the leg frame (x outward, z up), link vector to the next joint)
    joints: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]
    foot_site: bool = True
    slide_last: bool = False  # the last joint is a prismatic one along the link
    forward: str = "+x"


HEXAPOD_OTHER = Layout("hexapod_other", 3, 0.16, 0.09,
                       (((0, 0, 1), (0.03, 0, 0)), ((1, 0, 0), (0, 0, 0)), ((0, 1, 0), (0.09, 0, 0)),
                        ((0, 1, 0), (0.14, 0, -0.02))))  # yaw, roll, pitch, knee: 4 joints, other lengths
OCTOPOD = Layout("octopod", 4, 0.12, 0.07, (((0, 0, 1), (0.04, 0, 0)), ((0, -1, 0), (0.08, 0, 0)),
                                            ((0, -1, 0), (0.11, 0, 0))), foot_site=False)
QUADRUPED = Layout("quadruped", 2, 0.36, 0.08, (((1, 0, 0), (0, 0.05, 0)), ((0, 1, 0), (0, 0, -0.2)),
                                                ((0, 1, 0), (0, 0, -0.2))))  # abduction, hip, knee; legs down
SLIDER = Layout("hexapod_slider", 3, 0.18, 0.1, (((0, 0, 1), (0.05, 0, 0)), ((0, -1, 0), (0.1, 0, 0)),
                                                 ((0, 0, 1), (0.0, 0, -0.12))), slide_last=True)
LAYOUTS = (HEXAPOD_OTHER, OCTOPOD, QUADRUPED, SLIDER)


def build(layout: Layout) -> mujoco.MjSpec:
    """The robot on a floor; leg k of a side is `<side>{k}`, front first; forward +x."""
    spec = mujoco.MjSpec()
    spec.modelname = layout.name
    spec.compiler.degree = False
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05])
    trunk = spec.worldbody.add_body(name="base", pos=[0, 0, 0.3])
    trunk.add_freejoint(name="root")
    length = layout.spacing * (layout.pairs - 1) / 2 + 0.05
    trunk.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[length, layout.half_width, 0.03], mass=2.0)
    for side, sign in (("L", 1.0), ("R", -1.0)):
        for k in range(layout.pairs):
            x = layout.spacing * ((layout.pairs - 1) / 2 - k)
            # leg frame: x outward (+y on the left, -y on the right), z up
            quat = [np.cos(np.pi / 4), 0, 0, sign * np.sin(np.pi / 4)]
            _leg(layout, trunk.add_body(name=f"{side}{k}_mount", pos=[x, sign * layout.half_width, 0], quat=quat),
                 f"{side}{k}")
    return spec


def _leg(layout: Layout, parent, name: str) -> None:
    body = parent
    for i, (axis, link) in enumerate(layout.joints):
        body = body.add_body(name=f"{name}_link{i}", pos=[0, 0, 0] if i == 0 else list(layout.joints[i - 1][1]))
        slide = layout.slide_last and i == len(layout.joints) - 1
        body.add_joint(name=f"{name}_j{i}", type=mujoco.mjtJoint.mjJNT_SLIDE if slide else mujoco.mjtJoint.mjJNT_HINGE,
                       axis=list(link) if slide else list(axis), range=[-0.05, 0.05] if slide else [-2.5, 2.5],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE)
        if np.linalg.norm(link) > 0:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *link], size=[0.01, 0, 0], mass=0.05,
                          contype=0, conaffinity=0)
        else:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.012, 0, 0], mass=0.03, contype=0, conaffinity=0)
    tip = list(layout.joints[-1][1])
    body.add_geom(name=f"{name}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=tip, size=[0.015, 0, 0], mass=0.01)
    if layout.foot_site:
        body.add_site(name=f"{name}_tip", pos=tip)


def _package_file(package: str, rel: str) -> Path | None:
    spec = importlib.util.find_spec(package)  # finds the package without importing it
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(list(spec.submodule_search_locations)[0]) / rel
    return path if path.is_file() else None


def gymnasium_ant() -> Path | None:
    """Gymnasium's Ant (envs/mujoco/assets/ant.xml, MIT), from the installed wheel."""
    return _package_file("gymnasium", "envs/mujoco/assets/ant.xml")


def dm_control_quadruped() -> Path | None:
    """dm_control's suite quadruped (Apache-2.0): includes ./common/*.xml, an inline height
    field, coupled tendons, a ball with its own free joint. From the installed wheel."""
    return _package_file("dm_control", "suite/quadruped.xml")

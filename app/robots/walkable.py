"""An uploaded robot (app/robots/legmap.py ``Robot``) made ready for a walking search: its
damage applied by the leg map's names, its leg joints driven by position servos, and the
sensors and sites the recovery evaluator reads.

What is done to the stored (sanitised) model, in order:

- every actuator, sensor and keyframe of the upload is removed (what the upload had is
  reported: ``Walkable.upload_actuators``), and so is every other free-floating body (a
  ball to fetch, say); a trunk without a free joint gets one; the integrator is
  implicitfast (stable with stiff servos), the model's other options stay;
- damage: a **lost leg**'s subtree goes (from the first body of its chain); a **locked
  joint** is deleted and its body turned (hinge) or moved (slide) to the held value about
  the joint's anchor, an exact weld; a **passive joint** keeps its joint and its damping
  but gets no servo; a **weak joint**'s servo has its force limit scaled;
- a position servo (MuJoCo's ``pid`` actuator on the joint angle, control range the
  joint's) on every remaining driven leg joint, with the leg map's gains, else
  ``default_gains``;
- sensors ``torso_pos`` / ``torso_quat`` / ``com_pos`` on a heading site of the trunk
  (y forward, z up), contact sensors ``<leg>_ground`` on the trunk and on each leg's upper
  bodies (those carrying its first half of joints) against the world's geoms (the fall
  test), ``leg<n>_foot_touch`` on each foot body, and a site ``leg<n>_tip`` at each foot.

Legs are numbered 1..n front to back, left before right at each rank (odd left, even
right for a symmetric robot, as the built-in hexapod's).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from app.robots.damage import Damage, apply_damage, foot_in_body, name_parts
from app.robots.detect import _Kin, _path_to_trunk
from app.robots.legmap import Foot, Gains, Leg, LegMap, LegMapError, Robot

OBJ = mujoco.mjtObj
G = 9.81
# MIN_ARMATURE_RULE: armature >= 4 kp dt^2, so that a servo's stiffness against the joint's
# own inertia rotates at most half a radian of phase per step (omega dt <= 0.5).
HOLD_ERROR_RAD = 0.02  # a default servo gives its full torque at this error (about 1.1 deg)
SERVO_MARGIN = 2.0  # a default servo's torque: this many times a third of the weight held at the leg's reach


@dataclasses.dataclass
class Walkable:
    spec: mujoco.MjSpec  # the damaged, servoed robot (compile it, or edit it for perturbed copies)
    legs: LegMap  # the remaining legs, each with the joints left in the model (locked ones gone)
    numbers: dict[str, int]  # leg name -> leg number (1..n over the intact robot)
    passive: dict[str, list[str]]  # leg name -> its passive joints (in the model, not driven)
    gains: dict[str, dict]  # joint -> {"kp", "kd", "ki", "force_limit", "source": "leg map" | "default"}
    upload_actuators: dict[str, int]  # what the upload had: actuator kind -> count
    total_mass: float
    foot_radius: float


def leg_numbers(legs: LegMap) -> dict[str, int]:
    """Front to back (order), left before right at each rank: 1..n."""
    ranked = sorted(legs.legs, key=lambda l: (l.order, 0 if l.side == "left" else 1, l.name))
    return {l.name: k + 1 for k, l in enumerate(ranked)}


def inline_assets(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """No file left to read: each mesh read from a file gets its vertices and faces inline
    (as compiled, turned back into the file's frame and scale, so it compiles to the same
    mesh), each height field its elevation data; a texture read from a file becomes a flat
    grey one of the same type and skins are dropped (both drawn only). The robot.xml of a
    job's bundle is then the whole robot: the replay draws the uploaded meshes."""
    for i, mesh in enumerate(spec.meshes):
        if not mesh.file:
            continue
        k = mujoco.mj_name2id(model, OBJ.mjOBJ_MESH, mesh.name) if mesh.name else i
        v0, nv = model.mesh_vertadr[k], model.mesh_vertnum[k]
        f0, nf = model.mesh_faceadr[k], model.mesh_facenum[k]
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, model.mesh_quat[k])
        verts = model.mesh_vert[v0:v0 + nv] @ R.reshape(3, 3).T + model.mesh_pos[k]
        mesh.file, mesh.scale = "", [1.0, 1.0, 1.0]
        mesh.uservert = verts.ravel().tolist()
        mesh.userface = model.mesh_face[f0:f0 + nf].ravel().tolist()
    for i, hf in enumerate(spec.hfields):
        if not hf.file:
            continue
        k = mujoco.mj_name2id(model, OBJ.mjOBJ_HFIELD, hf.name) if hf.name else i
        a, nr, nc = model.hfield_adr[k], model.hfield_nrow[k], model.hfield_ncol[k]
        hf.file, hf.nrow, hf.ncol = "", int(nr), int(nc)
        hf.userdata = model.hfield_data[a:a + nr * nc].tolist()
    for tex in spec.textures:
        if tex.file or any(tex.cubefiles):
            tex.file, tex.cubefiles = "", [""] * len(tex.cubefiles)
            tex.builtin, tex.width, tex.height = mujoco.mjtBuiltin.mjBUILTIN_FLAT, 16, 16
            tex.rgb1 = tex.rgb2 = [0.6, 0.6, 0.6]
    for skin in list(spec.skins):
        spec.delete(skin)


def _leg_mass_and_reach(model: mujoco.MjModel, kin: _Kin, leg: Leg) -> tuple[float, float]:
    j0 = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, leg.joints[0])
    body = int(model.jnt_bodyid[j0])
    mass = float(model.body_subtreemass[body])
    reach = float(np.linalg.norm(kin.foot_point(leg.foot) - kin.data.xanchor[j0]))
    return mass, max(reach, 1e-3)


def default_gains(total_mass: float, leg_mass: float, reach: float, slide: bool = False) -> Gains:
    """The rule when the leg map gives none: the force limit is SERVO_MARGIN times the torque
    of holding a third of the robot's weight at the leg's reach (the foot's distance from its
    first joint at the stance); kp gives that torque at HOLD_ERROR_RAD of error (a slide:
    at 2 % of the reach); kd damps the leg critically as a rod of its mass and reach swung
    about its first joint (I = m r^2 / 3)."""
    load = total_mass * G / 3.0
    if slide:
        limit = SERVO_MARGIN * load
        kp = limit / (0.02 * reach)
        kd = 2.0 * math.sqrt(kp * leg_mass)
    else:
        limit = SERVO_MARGIN * load * reach
        kp = limit / HOLD_ERROR_RAD
        kd = 2.0 * math.sqrt(kp * leg_mass * reach**2 / 3.0)
    return Gains(kp=min(kp, 1e6), kd=min(kd, 1e5), force_limit=min(limit, 1e5))


def _actuator_kinds(model: mujoco.MjModel) -> dict[str, int]:
    out: dict[str, int] = {}
    for a in range(model.nu):
        g, b = model.actuator_gainprm[a], model.actuator_biasprm[a]
        if int(model.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_NONE):
            kind = "motor (torque)"
        elif b[1] != 0 and abs(b[1] + g[0]) < 1e-12:
            kind = "position servo"
        elif b[2] != 0 and b[1] == 0:
            kind = "velocity servo"
        else:
            kind = "other"
        out[kind] = out.get(kind, 0) + 1
    return out


def _strip(spec: mujoco.MjSpec, trunk: str) -> None:
    """No actuators, sensors, keyframes or other free bodies of the upload; the trunk floats."""
    for a in list(spec.actuators):
        spec.delete(a)
    for s in list(spec.sensors):
        spec.delete(s)
    for k in list(spec.keys):
        spec.delete(k)
    for b in list(spec.worldbody.bodies):
        if b.name != trunk and any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in b.joints):
            spec.delete(b)
    body = spec.body(trunk)
    if body is None or body.parent.name != spec.worldbody.name:
        raise LegMapError(f"trunk: {trunk!r} must be a body of the world (a free-floating trunk)")
    if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in body.joints):
        body.add_freejoint()
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST


TRUNK = "torso"  # the trunk's name in a walkable model (what the payload case and the sensors name)


def _rename(spec: mujoco.MjSpec, trunk: str) -> None:
    """The trunk becomes ``torso`` (a body of that name elsewhere is renamed first); the
    world's first plane becomes ``floor`` (the rough-floor case replaces it), one is added
    when the world has none."""
    other = spec.body(TRUNK)
    if other is not None and trunk != TRUNK:
        other.name = "gm_was_torso"
    spec.body(trunk).name = TRUNK
    planes = [g for g in spec.worldbody.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if spec.geom("floor") is not None and spec.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE:
        return
    if spec.geom("floor") is not None:
        spec.geom("floor").name = "gm_was_floor"
    if planes:
        planes[0].name = "floor"
    else:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05])


def _upper_bodies(model: mujoco.MjModel, trunk: int, leg: Leg) -> list[str]:
    """The bodies from the trunk down to the one carrying the leg's joint ceil(n/2) - 1."""
    upto = leg.joints[math.ceil(len(leg.joints) / 2) - 1]
    j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, upto)
    path = _path_to_trunk(model, int(model.jnt_bodyid[j]), trunk) or []
    return [mujoco.mj_id2name(model, OBJ.mjOBJ_BODY, b) for b in path]


def _foot_radius(model: mujoco.MjModel, data: mujoco.MjData, kin: _Kin, foot: Foot) -> float:
    """The radius of the collision geom of the foot's body nearest the foot point (sphere,
    capsule or cylinder end), 0 when none holds it."""
    body = {"site": lambda i: model.site_bodyid[i], "geom": lambda i: model.geom_bodyid[i],
            "body": lambda i: i}[foot.kind](mujoco.mj_name2id(model, {"site": OBJ.mjOBJ_SITE, "geom": OBJ.mjOBJ_GEOM,
                                                                     "body": OBJ.mjOBJ_BODY}[foot.kind], foot.name))
    p = kin.foot_point(foot)
    best = 0.0
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != body or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        r, half = float(model.geom_size[g, 0]), float(model.geom_size[g, 1])
        z = data.geom_xmat[g].reshape(3, 3)[:, 2]
        d = p - data.geom_xpos[g]
        t = float(np.clip(d @ z, -half, half)) if model.geom_type[g] in (int(mujoco.mjtGeom.mjGEOM_CAPSULE),) else 0.0
        if np.linalg.norm(d - t * z) <= r + 1e-6:
            best = max(best, r)
    return best


def _add_sensors(spec: mujoco.MjSpec, legs: LegMap, heading: np.ndarray, upper: list[str],
                 feet: dict[int, tuple[str, list[float]]]) -> None:
    """The sensors and sites the evaluator reads (see the module doc)."""
    trunk = spec.body(legs.trunk)
    trunk.add_site(name="gm_heading", quat=list(heading))
    types = (("torso_pos", mujoco.mjtSensor.mjSENS_FRAMEPOS), ("torso_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT))
    for name, typ in types:
        spec.add_sensor(name=name, type=typ, objtype=OBJ.mjOBJ_SITE, objname="gm_heading")
    spec.add_sensor(name="com_pos", type=mujoco.mjtSensor.mjSENS_SUBTREECOM, objtype=OBJ.mjOBJ_BODY,
                    objname=legs.trunk)
    for body in [legs.trunk, *upper]:
        spec.add_sensor(name=f"{body}_ground", type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=OBJ.mjOBJ_BODY,
                        objname=body, reftype=OBJ.mjOBJ_BODY, refname=spec.worldbody.name, intprm=[1, 1, 1])
    for n, (body, point) in sorted(feet.items()):
        spec.body(body).add_site(name=f"leg{n}_tip", pos=point)
        spec.add_sensor(name=f"leg{n}_foot_touch", type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=OBJ.mjOBJ_BODY,
                        objname=body, reftype=OBJ.mjOBJ_BODY, refname=spec.worldbody.name, intprm=[1, 1, 1])


def heading_quat(legs: LegMap) -> np.ndarray:
    """The trunk-frame rotation whose y axis is the leg map's forward and z is up."""
    fwd = np.array(legs.forward_vector())
    yaw = math.atan2(fwd[1], fwd[0]) - math.pi / 2  # turn +y onto forward about z
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def _servo(spec: mujoco.MjSpec, joint: str, g: Gains) -> None:
    from app.robots.mjcf import add_pid_servo

    limit = (g.force_limit if g.force_limit is not None else 1e5) * 1.0  # * 1.0: as when it took a scale
    add_pid_servo(spec, f"{joint}_servo", joint, g.kp, g.kd, limit, ki=g.ki if g.ki > 0 else None)


def make_walkable(robot: Robot, damage: Damage = Damage(), timestep: float | None = None) -> Walkable:
    """The damaged robot with servos and sensors (module doc); LegMapError names what does not fit.
    With ``timestep``, each driven joint's armature is raised to at least MIN_ARMATURE_RULE
    (its servo then stays stable at that step). The damage is made by app/robots/damage.py
    ``apply_damage`` on the servoed robot."""
    legs = robot.legs
    damage.check(legs)
    spec = robot.spec()
    name_parts(spec)
    model = spec.compile()
    inline_assets(spec, model)
    trunk = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk)
    kin = _Kin.at_rest(model, trunk)
    total = float(model.body_subtreemass[trunk])
    numbers = leg_numbers(legs)
    upload = _actuator_kinds(model)
    kept = [l for l in legs.legs if l.name not in damage.lost_legs]
    feet = {numbers[l.name]: foot_in_body(model, l.foot) for l in kept}
    radius = min((_foot_radius(model, kin.data, kin, l.foot) for l in kept), default=0.0)
    upper = sorted({b for l in kept for b in _upper_bodies(model, trunk, l)})
    gains = {}
    for leg in kept:
        mass, reach = _leg_mass_and_reach(model, kin, leg)
        for j in leg.joints:
            slide = int(model.jnt_type[mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, j)]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
            given = legs.gains_of(leg)
            g = given or default_gains(total, mass, reach, slide)
            gains[j] = g.model_dump() | {"source": "leg map" if given else "default"}
    _strip(spec, legs.trunk)
    for t in list(spec.tendons):
        spec.delete(t)
    for e in list(spec.equalities):
        spec.delete(e)
    for leg in kept:
        for j in leg.joints:
            _servo(spec, j, Gains(**{k: v for k, v in gains[j].items() if k != "source"}))
    applied = apply_damage(spec, legs, damage, rest=model)
    driven = {a.target for a in spec.actuators}
    for leg in kept:
        for j in leg.joints:
            if timestep is not None and j in driven:
                joint = spec.joint(j)
                joint.armature = max(float(joint.armature), 4.0 * gains[j]["kp"] * timestep**2)
                gains[j]["armature"] = float(joint.armature)
    for name, foot in applied.feet.items():
        feet[numbers[name]] = foot
    _rename(spec, legs.trunk)
    locked, passive = damage.locked(), damage.passive()
    left = LegMap(trunk=TRUNK, forward=legs.forward, stance_height=legs.stance_height, gains=legs.gains,
                  legs=[_without(l, locked, f"leg{numbers[l.name]}_tip" if l.name in applied.feet else None)
                        for l in kept])
    _add_sensors(spec, left, heading_quat(legs), [b for b in upper if b != legs.trunk], feet)
    return Walkable(spec=spec, legs=left, numbers={l.name: numbers[l.name] for l in kept},
                    passive={l.name: [j for j in l.joints if j in passive] for l in kept},
                    gains={j: g for j, g in gains.items() if j not in locked}, upload_actuators=upload,
                    total_mass=total, foot_radius=radius)


def _without(leg: Leg, locked: dict[str, float], foot_site: str | None = None) -> Leg:
    """The leg without its locked joints (and, shortened, with its foot at the new tip site)."""
    keep = [k for k, j in enumerate(leg.joints) if j not in locked]
    stance = None if leg.stance is None else [leg.stance[k] for k in keep]
    foot = leg.foot if foot_site is None else Foot(kind="site", name=foot_site)
    return leg.model_copy(update={"joints": [leg.joints[k] for k in keep], "stance": stance, "foot": foot})


def leg_length_m(robot: Robot) -> float:
    """An uploaded robot's leg length, as a built-in robot's is the sum of its leg's link
    lengths: per leg, the distances from each joint's anchor to the next joint's and from the
    last joint's to the foot, at the model's rest pose, summed; the mean over the legs (m)."""
    spec = robot.spec()
    name_parts(spec)
    model = spec.compile()
    legs = robot.legs
    kin = _Kin.at_rest(model, mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk))
    lengths = []
    for leg in legs.legs:
        points = [kin.data.xanchor[mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, j)] for j in leg.joints]
        points.append(kin.foot_point(leg.foot))
        lengths.append(sum(float(np.linalg.norm(b - a)) for a, b in zip(points, points[1:])))
    return float(np.mean(lengths))


def foot_segment_m(robot: Robot, leg: str) -> float:
    """The length of leg ``leg``'s foot segment at the model's rest pose: its last joint's
    anchor to its foot (m), what a shortened-leg damage cuts from (app/robots/damage.py)."""
    spec = robot.spec()
    name_parts(spec)
    model = spec.compile()
    kin = _Kin.at_rest(model, mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, robot.legs.trunk))
    l = robot.legs.leg(leg)
    anchor = kin.data.xanchor[mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, l.joints[-1])]
    return float(np.linalg.norm(kin.foot_point(l.foot) - anchor))

"""Find the legs of a compiled model, check a leg map against it, and say where its hips
and feet are (for the user to confirm the map, and for the preview).

Detection (docs/robots.md): the trunk is the free-floating top-level body with the most
hinge and slide joints below it. The trunk's rigid part is the trunk and every body
welded to it (no joint). Each child of the rigid part with joints below it and a contact
geom (contype or conaffinity non-zero) in its subtree is a leg; its foot is the contact
geom reaching farthest from the leg's root (a capsule or cylinder counts at its far end
cap), or a site on that geom's body at that point; its joints are the hinge and slide
joints on the path from the root to the foot, from the body out. Side: the hip (first
joint's anchor) left or right of the trunk's forward axis; order: front to back on each
side. Forward: the given axis, else +y when the hips spread over 1.25x more along y than
along x, else +x.
"""

from __future__ import annotations

import dataclasses
import os

import mujoco
import numpy as np

from app.robots.legmap import FORWARD_AXES, Foot, Leg, LegMap, LegMapError

J = mujoco.mjtJoint
OBJ = mujoco.mjtObj
LEG_JOINTS = (int(J.mjJNT_HINGE), int(J.mjJNT_SLIDE))
FREE = int(J.mjJNT_FREE)


def _name(model: mujoco.MjModel, obj, i: int) -> str:
    return mujoco.mj_id2name(model, obj, i) or ""


def _children(model: mujoco.MjModel) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {b: [] for b in range(model.nbody)}
    for b in range(1, model.nbody):
        out[int(model.body_parentid[b])].append(b)
    return out


def _subtree(children: dict[int, list[int]], root: int) -> list[int]:
    out, stack = [], [root]
    while stack:
        b = stack.pop()
        out.append(b)
        stack.extend(reversed(children[b]))
    return out


def find_trunk(model: mujoco.MjModel) -> int:
    children = _children(model)
    best, best_n = -1, -1
    for b in children[0]:
        jnts = range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if not any(int(model.jnt_type[j]) == FREE for j in jnts):
            continue
        n = sum(int(model.body_jntnum[c]) for c in _subtree(children, b) if c != b)
        if n > best_n:
            best, best_n = b, n
    if best < 0:
        raise LegMapError("no free-floating body (a top-level body with a free joint) to be the trunk")
    return best


@dataclasses.dataclass
class _Kin:
    """The model at its reference pose, positions in the trunk's frame."""

    model: mujoco.MjModel
    data: mujoco.MjData
    trunk: int

    @classmethod
    def at_rest(cls, model: mujoco.MjModel, trunk: int) -> _Kin:
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        return cls(model, data, trunk)

    def local(self, p: np.ndarray) -> np.ndarray:
        R = self.data.xmat[self.trunk].reshape(3, 3)
        return R.T @ (np.asarray(p) - self.data.xpos[self.trunk])

    def foot_point(self, foot: Foot) -> np.ndarray:
        """World position of a foot (object position plus its offset in the object's frame)."""
        d, m = self.data, self.model
        kinds = {"site": (OBJ.mjOBJ_SITE, d.site_xpos, d.site_xmat), "geom": (OBJ.mjOBJ_GEOM, d.geom_xpos, d.geom_xmat),
                 "body": (OBJ.mjOBJ_BODY, d.xpos, d.xmat)}
        obj, pos, mat = kinds[foot.kind]
        i = mujoco.mj_name2id(m, obj, foot.name)
        if i < 0:
            raise LegMapError(f"no {foot.kind} named {foot.name!r}")
        return pos[i] + mat[i].reshape(3, 3) @ np.asarray(foot.offset)


def _far_end(model: mujoco.MjModel, data: mujoco.MjData, g: int, ref: np.ndarray) -> tuple[np.ndarray, list[float]]:
    """A geom's point farthest along its axis from ref (capsule/cylinder end cap centre),
    with that point's offset in the geom frame."""
    centre = data.geom_xpos[g]
    if int(model.geom_type[g]) in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
        axis = data.geom_xmat[g].reshape(3, 3)[:, 2]
        half = float(model.geom_size[g, 1])
        ends = [(centre + s * half * axis, [0.0, 0.0, s * half]) for s in (1.0, -1.0)]
        return max(ends, key=lambda e: float(np.linalg.norm(e[0] - ref)))
    return centre.copy(), [0.0, 0.0, 0.0]


def _foot(kin: _Kin, bodies: list[int], root: int) -> tuple[Foot, int]:
    m, d = kin.model, kin.data
    ref = d.xpos[root]
    best = None
    for b in bodies:
        for g in range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b]):
            if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            point, offset = _far_end(m, d, g, ref)
            dist = float(np.linalg.norm(point - ref))
            if best is None or dist > best[0] + 1e-9:
                best = (dist, g, point, offset)
    if best is None:
        raise LegMapError("no contact geom")
    _, g, point, offset = best
    body = int(m.geom_bodyid[g])
    radius = float(m.geom_size[g, 0])
    for s in range(m.nsite):
        if m.site_bodyid[s] == body and _name(m, OBJ.mjOBJ_SITE, s) and \
                np.linalg.norm(d.site_xpos[s] - point) <= max(1e-3, 0.5 * radius):
            return Foot(kind="site", name=_name(m, OBJ.mjOBJ_SITE, s)), body
    name = _name(m, OBJ.mjOBJ_GEOM, g)
    if name:
        return Foot(kind="geom", name=name, offset=[round(v, 9) for v in offset]), body
    local = d.xmat[body].reshape(3, 3).T @ (point - d.xpos[body])
    bname = _name(m, OBJ.mjOBJ_BODY, body)
    if not bname:
        raise LegMapError("the foot's geom and body have no names: name one of them")
    return Foot(kind="body", name=bname, offset=[round(float(v), 9) for v in local]), body


def _path(model: mujoco.MjModel, root: int, foot_body: int) -> list[int]:
    out = [foot_body]
    while out[-1] != root:
        out.append(int(model.body_parentid[out[-1]]))
    return out[::-1]


def _leg_joints(model: mujoco.MjModel, path: list[int]) -> list[int]:
    joints = []
    for b in path:
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            if int(model.jnt_type[j]) not in LEG_JOINTS:
                raise LegMapError(f"body {_name(model, OBJ.mjOBJ_BODY, b)!r} of a leg has a ball or free joint")
            if not _name(model, OBJ.mjOBJ_JOINT, j):
                raise LegMapError(f"a joint of body {_name(model, OBJ.mjOBJ_BODY, b)!r} has no name")
            joints.append(j)
    return joints


def _common_affix(names: list[str]) -> str:
    names = [n for n in names if n]
    if len(names) < 2:
        return ""
    pre = os.path.commonprefix(names).rstrip("_-.:")
    suf = os.path.commonprefix([n[::-1] for n in names])[::-1].lstrip("_-.:")
    best = max(pre, suf, key=len)
    return best if len(best) >= 2 else ""


def _leg_name(model: mujoco.MjModel, path: list[int], joints: list[int], k: int, trunk: int) -> str:
    import re

    mount = int(model.body_parentid[path[0]])  # a body welded to the trunk that carries the leg
    bodies = [_name(model, OBJ.mjOBJ_BODY, b) for b in ([mount] if mount != trunk else []) + path]
    jn = [_name(model, OBJ.mjOBJ_JOINT, j) for j in joints]
    name = _common_affix(bodies) or _common_affix(jn) or bodies[0] or f"leg{k}"
    name = re.sub(r"[^A-Za-z0-9_.\-]", "_", name)[:64].lstrip(".-") or f"leg{k}"
    return name


def _guess_forward(hips: list[np.ndarray]) -> str:
    h = np.array(hips)
    ext = h.max(axis=0) - h.min(axis=0) if len(h) else np.zeros(3)
    return "+y" if ext[1] > 1.25 * ext[0] else "+x"


def _rigid_part(model: mujoco.MjModel, children: dict[int, list[int]], trunk: int) -> list[int]:
    out, stack = [], [trunk]
    while stack:
        b = stack.pop()
        out.append(b)
        stack.extend(c for c in children[b] if model.body_jntnum[c] == 0 and c not in out)
    return out


@dataclasses.dataclass
class _Found:
    name: str
    hip: np.ndarray  # trunk frame
    joints: list[str]
    foot: Foot


def _find_legs(kin: _Kin) -> list[_Found]:
    m = kin.model
    children = _children(m)
    rigid = _rigid_part(m, children, kin.trunk)
    found: list[_Found] = []
    for parent in rigid:
        for root in children[parent]:
            if root in rigid:
                continue
            sub = _subtree(children, root)
            if not any(m.body_jntnum[b] for b in sub):
                continue
            try:
                foot, foot_body = _foot(kin, sub, root)
            except LegMapError:
                continue  # no contact geom: not a leg (an antenna, a camera mast)
            path = _path(m, root, foot_body)
            joints = _leg_joints(m, path)
            if not joints:
                continue
            hip = kin.local(kin.data.xanchor[joints[0]])
            name = _leg_name(m, path, joints, len(found) + 1, kin.trunk)
            found.append(_Found(name, hip, [_name(m, OBJ.mjOBJ_JOINT, j) for j in joints], foot))
    return found


def detect_legs(model: mujoco.MjModel, forward: str | None = None) -> LegMap:
    """The leg map the kinematic tree suggests; LegMapError when it finds no legs."""
    if forward is not None and forward not in FORWARD_AXES:
        raise LegMapError(f"forward must be one of {sorted(FORWARD_AXES)}, got {forward!r}")
    trunk = find_trunk(model)
    kin = _Kin.at_rest(model, trunk)
    found = _find_legs(kin)
    if not found:
        raise LegMapError("no legs found: no chain of hinge or slide joints from the trunk to a contact geom")
    if len(found) > 16:
        raise LegMapError(f"{len(found)} leg-like chains found; at most 16 legs")
    forward = forward or _guess_forward([f.hip for f in found])
    fwd = np.array(FORWARD_AXES[forward])
    left = np.cross([0.0, 0.0, 1.0], fwd)
    sides = {}
    for f in found:
        lat = float(left @ f.hip)
        if abs(lat) < 1e-6:
            raise LegMapError(f"leg {f.name!r} has its hip on the trunk's centre line: give the leg map explicitly")
        sides[f.name] = "left" if lat > 0 else "right"
    names = _unique([f.name for f in found])
    legs = []
    for side in ("left", "right"):
        mine = sorted((f for f in found if sides[f.name] == side), key=lambda f: -float(fwd @ f.hip))
        for order, f in enumerate(mine):
            legs.append((float(-fwd @ f.hip), side, order, f))
    legs.sort(key=lambda t: (round(t[0], 6), t[1] == "right"))
    return LegMap(trunk=_name(model, OBJ.mjOBJ_BODY, trunk) or _unnamed("trunk"), forward=forward,
                  legs=[Leg(name=names[found.index(f)], side=side, order=order, joints=f.joints, foot=f.foot)
                        for _, side, order, f in legs])


def _unnamed(what: str):
    raise LegMapError(f"the {what} body has no name: name it in the model")


def _unique(names: list[str]) -> list[str]:
    out = []
    for n in names:
        base, k = n, 2
        while n in out:
            n, k = f"{base}_{k}", k + 1
        out.append(n)
    return out


def check_legs(model: mujoco.MjModel, legs: LegMap) -> None:
    """LegMapError unless every name exists and each leg is a chain of its joints, from the
    trunk out, ending at its foot (no other joint on that path)."""
    trunk = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk)
    if trunk < 0:
        raise LegMapError(f"trunk: no body named {legs.trunk!r}")
    if trunk != find_trunk(model) and not _is_free(model, trunk):
        raise LegMapError(f"trunk: body {legs.trunk!r} is not a free-floating top-level body")
    kin = _Kin.at_rest(model, trunk)
    for leg in legs.legs:
        where = f"leg {leg.name!r}"
        ids = []
        for jn in leg.joints:
            j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, jn)
            if j < 0:
                raise LegMapError(f"{where}: no joint named {jn!r}")
            if int(model.jnt_type[j]) not in LEG_JOINTS:
                raise LegMapError(f"{where}: joint {jn!r} is not a hinge or slide joint")
            ids.append(j)
        try:
            kin.foot_point(leg.foot)
        except LegMapError as e:
            raise LegMapError(f"{where}: foot: {e}") from None
        foot_body = _foot_body(model, leg.foot)
        path = _path_to_trunk(model, foot_body, trunk)
        if path is None:
            raise LegMapError(f"{where}: its foot is not on a body below the trunk")
        on_path = [j for b in path for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])]
        if on_path != ids:
            names = [_name(model, OBJ.mjOBJ_JOINT, j) for j in on_path]
            raise LegMapError(f"{where}: joints must be those from the trunk to the foot, in order: {names}")


def _is_free(model: mujoco.MjModel, b: int) -> bool:
    return model.body_parentid[b] == 0 and any(
        int(model.jnt_type[j]) == FREE for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]))


def _foot_body(model: mujoco.MjModel, foot: Foot) -> int:
    if foot.kind == "body":
        return mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, foot.name)
    if foot.kind == "geom":
        return int(model.geom_bodyid[mujoco.mj_name2id(model, OBJ.mjOBJ_GEOM, foot.name)])
    return int(model.site_bodyid[mujoco.mj_name2id(model, OBJ.mjOBJ_SITE, foot.name)])


def _path_to_trunk(model: mujoco.MjModel, body: int, trunk: int) -> list[int] | None:
    """Bodies from just below the trunk down to `body`, or None if body is not below it."""
    path = [body]
    while path[-1] != trunk:
        if path[-1] == 0:
            return None
        path.append(int(model.body_parentid[path[-1]]))
    return path[-2::-1]


def leg_points(model: mujoco.MjModel, legs: LegMap, qpos: np.ndarray | None = None) -> dict[str, dict]:
    """Each leg's hip (first joint's anchor) and foot, in the trunk frame (m), at qpos
    (default: the model's reference pose): the top view and the preview draw these."""
    trunk = mujoco.mj_name2id(model, OBJ.mjOBJ_BODY, legs.trunk)
    kin = _Kin(model, mujoco.MjData(model), trunk)
    if qpos is not None:
        kin.data.qpos[:] = qpos
    mujoco.mj_kinematics(model, kin.data)
    out = {}
    for leg in legs.legs:
        j = mujoco.mj_name2id(model, OBJ.mjOBJ_JOINT, leg.joints[0])
        out[leg.name] = {"hip": [round(float(v), 6) for v in kin.local(kin.data.xanchor[j])],
                         "foot": [round(float(v), 6) for v in kin.local(kin.foot_point(leg.foot))]}
    return out

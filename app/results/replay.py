"""3D replay of simulated trajectories with viser.

The robot's geometry is taken from the MuJoCo model (one viser frame per body, its geoms
as primitives under it) and sent once; every replay frame then only moves the body
frames (poses, not meshes). ``record`` writes a ``.viser`` scene recording that viser's
own client plays back with ``?playbackPath=``; ``record_scenes`` records one scene per
track (the bundle's ``replay.viser`` is the method's answer alone, ``replay/<name>.viser``
each other track: one robot is what a software renderer draws smoothly); ``serve_live``
opens a live server with a timeline slider, play/pause, speed and a recovered/baseline toggle.
"""

from __future__ import annotations

import contextlib
import io
import re
import socket
import threading
from collections.abc import Mapping

import mujoco
import numpy as np

from app.core.colors import rgb
from app.jobs.base import ReplayTrack

_G = mujoco.mjtGeom


def replay_tracks(kind, names: list[str]) -> list[ReplayTrack]:
    """The traces to replay, in the kind's order, with its labels and colour roles (the
    colours of app/core/colors.py, as in the plots); ``kind`` None: every trace as it comes."""
    if kind is None:
        return [ReplayTrack(n, n, None, i) for i, n in enumerate(names)]
    tracks = [t for t in kind.replay_style(list(names)) if t.name in names]
    return sorted(tracks, key=lambda t: t.order)


SCENE = "replay.viser"  # the first track's scene (the method's answer), where it always was


def scene_paths(names: list[str]) -> dict[str, str]:
    """Bundle member of each track's scene, tracks in the kind's order: the first is
    ``replay.viser`` (links to it and `gaitmend` readers of a bundle keep working), each
    other ``replay/<name>.viser``."""
    return {n: SCENE if i == 0 else f"replay/{re.sub(r'[^A-Za-z0-9_-]', '_', n)}.viser" for i, n in enumerate(names)}


def scene_rows(tracks: list[ReplayTrack]) -> dict[str, str]:
    """The bundle README's row of each track's scene."""
    paths = scene_paths([t.name for t in tracks])
    return {paths[t.name]: f"3D replay of {t.label} alone (trace `{t.name}`): a viser scene recording "
                           "(the dashboard plays it; `gaitmend replay` shows every track live)" for t in tracks}


def record_scenes(model: mujoco.MjModel, traces: Mapping[str, Mapping[str, np.ndarray]],
                  tracks: list[ReplayTrack], fps: float = 25.0) -> dict[str, bytes]:
    """One .viser recording per track, {bundle member: bytes} (``scene_paths``): each robot
    alone on its own ground, the camera framing (or following) its own path."""
    paths = scene_paths([t.name for t in tracks])
    return {paths[t.name]: record(model, {t.name: traces[t.name]}, fps, [t]) for t in tracks}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rgb(rgba) -> tuple[int, int, int]:
    return tuple(int(255 * c) for c in rgba[:3])


def add_model(scene, prefix: str, model: mujoco.MjModel, tint=None, window=None) -> dict[int, object]:
    """One frame per body (world excluded) with its geoms; returns body id -> frame handle.
    ``window`` ((x0, y0), (x1, y1)): the world's own geoms are drawn only inside it (robots
    side by side each stand on their own patch of the field, not on a neighbour's zones)."""
    frames = {}
    for b in range(1, model.nbody):
        frames[b] = scene.add_frame(f"{prefix}/body{b}", show_axes=False)
    root = _root_body(model)
    robot = {b for b in range(1, model.nbody) if b == root or _descends(model, b, root)}
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b == 0 and int(model.geom_type[g]) == _G.mjGEOM_PLANE:
            continue  # the ground is drawn as a grid
        if b == 0 and window is not None and int(model.geom_type[g]) != _G.mjGEOM_HFIELD and \
                not all(window[0][i] <= model.geom_pos[g][i] <= window[1][i] for i in (0, 1)):
            continue
        name = f"{prefix}/body{b}/geom{g}" if b else f"{prefix}/static/geom{g}"
        t = int(model.geom_type[g])
        size = model.geom_size[g]
        pos, quat = model.geom_pos[g].copy(), model.geom_quat[g].copy()
        # the world's own geoms (terrain, forbidden zones, obstacles) and bodies that are not the
        # robot's (tipping's tilting platform) keep their colours: tinted in the run's colour they
        # read as part of the robot (zones looked like footholds, the platform like its body)
        color = tint if tint is not None and t != _G.mjGEOM_SPHERE and b in robot else _rgb(model.geom_rgba[g])
        if t == _G.mjGEOM_HFIELD:
            _add_hfield(scene, name, model, g, color, pos, quat, window)
        elif t == _G.mjGEOM_BOX:
            scene.add_box(name, color=color, dimensions=tuple(2 * size), position=pos, wxyz=quat)
        elif t == _G.mjGEOM_SPHERE:
            scene.add_icosphere(name, radius=float(size[0]), color=color, subdivisions=2, position=pos, wxyz=quat)
        elif t in (_G.mjGEOM_CAPSULE, _G.mjGEOM_CYLINDER):
            # MuJoCo's capsule/cylinder axis is the geom's local z, as is viser's cylinder.
            scene.add_cylinder(name, radius=float(size[0]), height=float(2 * size[1]), color=color,
                               radial_segments=12, position=pos, wxyz=quat)
            if t == _G.mjGEOM_CAPSULE:  # caps are children: positions in the cylinder's frame
                for k, sgn in enumerate((-1, 1)):
                    scene.add_icosphere(f"{name}/cap{k}", radius=float(size[0]), color=color, subdivisions=1,
                                        position=(0.0, 0.0, sgn * float(size[1])))
        elif t == _G.mjGEOM_ELLIPSOID:
            scene.add_icosphere(name, radius=1.0, scale=tuple(size), color=color, subdivisions=2, position=pos, wxyz=quat)
        elif t == _G.mjGEOM_MESH:
            m = int(model.geom_dataid[g])
            va, vn = model.mesh_vertadr[m], model.mesh_vertnum[m]
            fa, fn = model.mesh_faceadr[m], model.mesh_facenum[m]
            scene.add_mesh_simple(name, vertices=model.mesh_vert[va : va + vn], faces=model.mesh_face[fa : fa + fn],
                                  color=color, position=pos, wxyz=quat)
    return frames


def _add_hfield(scene, name: str, model: mujoco.MjModel, g: int, color, pos, quat, window=None,
                max_side: int = 64) -> None:
    """A height field (rough ground) as a triangle mesh, thinned to at most max_side points a
    side, cut to ``window`` (world x, y) when given (an unrotated field: the worlds here).
    64 a side: a software renderer drew freegait's scene at about half the frame rate with
    160, and the relief (freegait's is smooth over 0.12 m) still reads at a few cm a point."""
    h = int(model.geom_dataid[g])
    nrow, ncol = int(model.hfield_nrow[h]), int(model.hfield_ncol[h])
    rx, ry, top, _bottom = model.hfield_size[h]
    z = model.hfield_data[model.hfield_adr[h]: model.hfield_adr[h] + nrow * ncol].reshape(nrow, ncol) * top
    xs, ys = np.linspace(-rx, rx, ncol), np.linspace(-ry, ry, nrow)
    if window is not None:
        cx = (xs + pos[0] >= window[0][0]) & (xs + pos[0] <= window[1][0])
        cy = (ys + pos[1] >= window[0][1]) & (ys + pos[1] <= window[1][1])
        if cx.sum() < 2 or cy.sum() < 2:
            return
        z, xs, ys = z[np.ix_(cy, cx)], xs[cx], ys[cy]
    step = max(1, -(-max(z.shape) // max_side))
    z, xs, ys = z[::step, ::step], xs[::step], ys[::step]
    ny, nx = z.shape
    gx, gy = np.meshgrid(xs, ys)
    verts = np.stack([gx.ravel(), gy.ravel(), z.ravel()], axis=1).astype(np.float32)
    i = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.uint32)
    scene.add_mesh_simple(name, vertices=verts, faces=faces, color=color, position=pos, wxyz=quat)


def _root_body(model: mujoco.MjModel) -> int:
    """The robot's floating base: the body of the first free joint (else body 1)."""
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    return int(model.jnt_bodyid[free[0]]) if free.size else 1


def _robot_size(model: mujoco.MjModel, root: int, xpos: np.ndarray, xquat: np.ndarray) -> float:
    """Radius of the robot (its base's subtree) at the first frame."""
    sub = [b for b in range(model.nbody) if b == root or _descends(model, b, root)]
    return max(0.1, float(np.linalg.norm(xpos[0, sub] - xpos[0, root], axis=1).max()))


def _descends(model: mujoco.MjModel, b: int, root: int) -> bool:
    while b > 0:
        b = int(model.body_parentid[b])
        if b == root:
            return True
    return False


def body_poses(model: mujoco.MjModel, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World poses (T, nbody, 3) and (T, nbody, 4) of every body along a qpos trajectory."""
    data = mujoco.MjData(model)
    T = qpos.shape[0]
    xpos = np.empty((T, model.nbody, 3))
    xquat = np.empty((T, model.nbody, 4))
    for i in range(T):  # forward kinematics of already simulated frames, at replay rate
        data.qpos[:] = qpos[i]
        mujoco.mj_kinematics(model, data)
        xpos[i], xquat[i] = data.xpos, data.xquat
    return xpos, xquat


def _frames(traces: Mapping[str, Mapping[str, np.ndarray]], fps: float):
    """Common replay clock: sample indices per trace at `fps` from time 0 (gait start)."""
    out = {}
    for name, tr in traces.items():
        t = np.asarray(tr["time_s"])
        clock = np.arange(max(t[0], -0.5), t[-1] + 1e-9, 1.0 / fps)
        out[name] = np.clip(np.searchsorted(t, clock), 0, len(t) - 1)
    n = max(len(v) for v in out.values())
    return {k: np.pad(v, (0, n - len(v)), mode="edge") for k, v in out.items()}, n


class _Scene:
    """Robots of several traces side by side (the second and later shifted along -x),
    ground, body paths, foot contacts. Sizes scale with the robot (a JetHexa is 0.3 m, a
    heavy-duty hexapod 5 m). The camera frames the whole walk; a walk longer than
    ``FOLLOW_SIZES`` robot sizes is followed instead: everything hangs under one world frame
    that ``show`` moves back by the first robot's progress, so that robot stays where the
    camera looks while the ground slides under it (a recording cannot move viser's camera)."""

    FOLLOW_SIZES = 12.0

    def __init__(self, server, model: mujoco.MjModel, traces, fps: float, tracks: list[ReplayTrack] | None = None):
        self.server, self.model = server, model
        scene = server.scene
        scene.set_up_direction("+z")
        # no dynamic shadows: a software renderer (SwiftShader, no GPU) drew a one-robot scene
        # at about half the frame rate with them; the contact dots show where the feet touch
        scene.configure_default_lights(enabled=True, cast_shadow=False)
        # nor image-based lighting: unless told otherwise viser's client lights every standard
        # material with a default environment map, sampled per pixel, and that halved a software
        # renderer's frame rate on freegait's rough ground (issue 25: 2.6 against 5.4 frames/s); a
        # hemisphere light (white sky above, brown-grey ground below: placed on +z, or viser's
        # client lights every face evenly) keeps faces shaded by where they face
        scene.configure_environment_map(hdri=None)
        scene.add_light_hemisphere("/hemisphere", sky_color=(255, 255, 255), ground_color=(120, 110, 100),
                                   intensity=3.0, position=(0.0, 0.0, 1.0))
        idx, self.n = _frames(traces, fps)
        self.fps = fps
        poses = {name: body_poses(model, np.asarray(tr["qpos"])[idx[name]]) for name, tr in traces.items()}
        root = _root_body(model)
        size = _robot_size(model, root, *next(iter(poses.values())))
        spacing = 3.2 * size
        lo, hi = self._extent(poses, root, spacing)
        lead = next(iter(poses.values()))[0][:, root, :2]
        self.follow = lead - lead[0] if float(np.linalg.norm((hi - lo)[:2])) > self.FOLLOW_SIZES * size else None
        self._frame_camera(server, *(self._extent(poses, root, spacing, 0.1) if self.follow is not None else (lo, hi)),
                           size)
        self.world = scene.add_frame("/world", show_axes=False)
        # the ground spans every robot (side by side along -x) and every path, however far it goes
        span = hi - lo + 8 * size
        scene.add_grid("/world/ground", width=float(span[0]), height=float(span[1]), cell_size=size / 2.5,
                       section_size=2 * size, position=(float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2, 0.0))
        style = {t.name: t for t in (tracks or replay_tracks(None, list(traces)))}
        self.robots = {name: self._robot(scene, name, style.get(name, ReplayTrack(name, name, None, k)), tr, idx[name],
                                         poses[name], root, size, np.array([-spacing * k, 0.0, 0.0]))
                       for k, (name, tr) in enumerate(traces.items())}
        self.show(0)

    def _robot(self, scene, name: str, track: ReplayTrack, tr, idx, pose, root: int, size: float, offset) -> dict:
        color = rgb(track.color)
        node = scene.add_frame(f"/world/{name}", show_axes=False, position=tuple(offset))
        xpos, xquat = pose
        # this robot's own patch of the world: its path, a robot's size around it, and never
        # more than half the spacing sideways (the next robot's patch begins there)
        lo, hi = xpos[:, root, :2].min(axis=0), xpos[:, root, :2].max(axis=0)
        half = 0.5 * 3.2 * size
        window = ((lo[0] - half, lo[1] - 2.5 * size), (hi[0] + half, hi[1] + 2.5 * size))
        frames = add_model(scene, f"/world/{name}", self.model, tint=color, window=window)
        path = xpos[:, root, :2]
        pts = np.concatenate([path[:-1, None], path[1:, None]], axis=1)
        pts = np.concatenate([pts, np.full(pts.shape[:2] + (1,), 0.01 * size)], axis=2)
        scene.add_line_segments(f"/world/{name}/path", points=pts, colors=color, thickness=0.015 * size)
        # the label rides above the robot (show() moves it), named as the page names the trace
        label = scene.add_label(f"/world/{name}/label", track.label,
                                position=tuple(xpos[0, root] + np.array([0.0, 0.0, 1.3 * size])))
        contacts = scene.add_point_cloud(f"/world/{name}/contacts", points=np.zeros((1, 3)), colors=(20, 160, 60),
                                         point_size=0.1 * size, point_shape="circle")
        return {"root": node, "frames": frames, "xpos": xpos, "xquat": xquat, "feet": self._feet(tr, idx),
                "contacts": contacts, "lift": 0.01 * size, "label": label, "root_body": root, "label_up": 1.3 * size}

    @staticmethod
    def _extent(poses, root: int, spacing: float, upto: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """The box the robots' bases sweep (side by side, spaced along -x) in the first
        ``upto`` share of the replay."""
        pts = np.concatenate([xpos[: max(1, int(round(len(xpos) * upto))), root] + np.array([-spacing * k, 0.0, 0.0])
                              for k, (xpos, _) in enumerate(poses.values())])
        return pts.min(axis=0), pts.max(axis=0)

    @staticmethod
    def _frame_camera(server, lo: np.ndarray, hi: np.ndarray, size: float) -> None:
        """Point the camera at the box ``lo``-``hi`` from a distance at which that box, plus a
        robot's size around it, fills the view: the robots are what one sees, not the grid."""
        centre = 0.5 * (lo + hi)
        radius = 0.5 * float(np.linalg.norm((hi - lo)[:2])) + 1.2 * size
        fov = 75.0 * np.pi / 180.0  # viser's default vertical field of view
        dist = radius / np.tan(fov / 2) * 1.05
        view = np.array([0.55, -0.65, 0.52])
        server.initial_camera.look_at = tuple(centre)
        server.initial_camera.position = tuple(centre + dist * view / np.linalg.norm(view))

    @staticmethod
    def _feet(tr, idx):
        if "feet_m" not in tr or "foot_contact" not in tr:
            return None
        return np.asarray(tr["feet_m"])[idx], np.asarray(tr["foot_contact"])[idx]

    def show(self, i: int) -> None:
        if self.follow is not None:
            self.world.position = (-float(self.follow[i, 0]), -float(self.follow[i, 1]), 0.0)
        for r in self.robots.values():
            r["label"].position = tuple(r["xpos"][i, r["root_body"]] + np.array([0.0, 0.0, r["label_up"]]))
            for b, h in r["frames"].items():
                h.position = r["xpos"][i, b]
                h.wxyz = r["xquat"][i, b]
            if r["feet"] is not None:
                feet, on = r["feet"][0][i], r["feet"][1][i]
                pts = feet[on] if on.any() else np.zeros((0, 3))
                pts = pts.copy()
                if len(pts):
                    pts[:, 2] += r["lift"]
                r["contacts"].points = pts if len(pts) else np.full((1, 3), np.nan)


def record(model: mujoco.MjModel, traces: Mapping[str, Mapping[str, np.ndarray]], fps: float = 25.0,
           tracks: list[ReplayTrack] | None = None) -> bytes:
    """A .viser scene recording of the traces playing in real time."""
    import viser

    quiet = io.StringIO()  # viser prints a banner even with verbose=False
    with contextlib.redirect_stdout(quiet):
        server = viser.ViserServer(host="127.0.0.1", port=_free_port(), verbose=False)
    try:
        sc = _Scene(server, model, traces, fps, tracks)
        ser = server.get_scene_serializer()
        for i in range(sc.n):
            sc.show(i)
            ser.insert_sleep(1.0 / fps)
        return ser.serialize()
    finally:
        with contextlib.redirect_stdout(quiet):
            server.stop()


def serve_live(model: mujoco.MjModel, traces, host: str = "127.0.0.1", port: int = 8081, fps: float = 25.0,
               stop: threading.Event | None = None, tracks: list[ReplayTrack] | None = None):
    """Live viser server: timeline slider, play/pause, speed, recovered/baseline toggle.
    Blocks until ``stop`` is set (or forever)."""
    import viser

    server = viser.ViserServer(host=host, port=port, verbose=False)
    sc = _Scene(server, model, traces, fps, tracks)
    gui = server.gui
    # Integer frames: the client drops the connection on float slider values pushed by
    # the server at replay rate (viser 1.1.1), so time is shown as text beside it.
    frame = gui.add_slider(f"frame ({fps:g}/s)", min=0, max=sc.n - 1, step=1, initial_value=0)
    clock = gui.add_text("time (s)", initial_value="0.00", disabled=True)
    playing = gui.add_checkbox("play", initial_value=True)
    speed = gui.add_dropdown("speed", options=("0.25x", "0.5x", "1x", "2x", "4x"), initial_value="1x")
    labels = {t.name: t.label for t in (tracks or [])}
    toggles = {name: gui.add_checkbox(f"show {labels.get(name, name)}", initial_value=True) for name in sc.robots}

    state = {"i": 0, "pos": 0.0, "own": False}

    @frame.on_update
    def _(_event) -> None:
        if not state["own"]:  # the user dragged the slider
            state["i"] = int(frame.value)
            state["pos"] = float(state["i"])
            sc.show(state["i"])
            clock.value = f"{state['i'] / fps:.2f}"

    for name, cb in toggles.items():
        def _toggle(_event, name=name, cb=cb) -> None:
            sc.robots[name]["root"].visible = cb.value  # hides the whole subtree
        cb.on_update(_toggle)

    stop = stop or threading.Event()
    while not stop.wait(1.0 / fps):
        if not playing.value:
            continue
        state["pos"] = (state["pos"] + float(speed.value[:-1])) % sc.n  # frames advance by the speed factor
        state["i"] = int(state["pos"])
        with server.atomic():
            sc.show(state["i"])
            state["own"] = True
            frame.value = state["i"]
            state["own"] = False
            clock.value = f"{state['i'] / fps:.2f}"
    server.stop()
    return server

"""Videos of a result: the recovered gait and its baseline side by side, rendered with
MuJoCo's offscreen renderer, captioned, encoded as H.264 MP4 (PyAV, whose wheel ships
FFmpeg and libx264); and a small animated WebP thumbnail of the first trace.

No display and no GPU are needed: the OpenGL context is EGL by default, which Mesa
serves with its llvmpipe software rasteriser (Debian: libegl1, libegl-mesa0,
libgl1-mesa-dri); MUJOCO_GL=osmesa picks OSMesa instead (Debian: libosmesa6). The
context is made here, whatever MUJOCO_GL said when mujoco was imported.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import zipfile
from collections.abc import Mapping
from fractions import Fraction
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from app.jobs.base import ReplayTrack, SpecError

WIDTH, HEIGHT, FPS = 1280, 720, 30  # `gaitmend video` defaults: 720p at 30 frames per second
THUMB_WIDTH, THUMB_HEIGHT, THUMB_FPS, THUMB_SECONDS = 240, 136, 8, 4.0
CAMERAS = ("follow", "fixed")
GL_PACKAGES = {"egl": "libegl1 libegl-mesa0 libgl1-mesa-dri", "osmesa": "libosmesa6"}


class RenderError(RuntimeError):
    """The bundle cannot be rendered (nothing replayable) or there is no OpenGL here."""


@dataclasses.dataclass
class Clip:
    """What a video shows: the model, the traces (each with ``time_s`` and ``qpos``) in
    display order with their labels, and the caption lines."""

    model_xml: str
    traces: dict[str, Mapping[str, np.ndarray]]
    tracks: list[ReplayTrack]
    caption: list[str]


# -- reading a bundle ------------------------------------------------------------------------------

def bundle_files(path: Path) -> dict[str, bytes]:
    """Every member of a bundle zip or unpacked bundle folder, by its name in the bundle."""
    path = Path(path)
    if path.is_dir():
        return {p.relative_to(path).as_posix(): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist() if not n.endswith("/")}


def caption_lines(kind, spec: dict | None, summary: dict | None) -> list[str]:
    """The caption: robot and damage in the kind's words, then the headline rows that state
    a target (met or not) and the first rows with a unit (e.g. the distance walked)."""
    first = [kind.title if kind is not None else "gaitmend"]
    if kind is not None and spec:
        first.append(f"robot {spec.get('robot', '-')}")
        try:
            first.append(f"damage: {kind.damage_text(kind.Spec.parse(spec))}")
        except (SpecError, KeyError, TypeError, ValueError, AttributeError):
            pass
    lines = ["  |  ".join(first)]
    if kind is not None and summary:
        try:
            rows = kind.headline(summary)
        except (KeyError, TypeError, ValueError, IndexError):
            rows = []
        picked = [r for r in rows if r["met"] is not None][:2]
        picked += [r for r in rows if r["unit"] and r not in picked][: max(0, 3 - len(picked))]
        lines.append("  |  ".join(_row_text(r) for r in picked))
    return [ln for ln in lines if ln]


def _value_text(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_value_text(x) for x in v) + ")"
    return "-" if v is None else str(v)


def _row_text(r: dict) -> str:
    v = _value_text(r["value"])
    mark = "" if r["met"] is None or v in ("met", "not met") else (" (target met)" if r["met"] else " (target missed)")
    return f"{r['label']} {v}{(' ' + r['unit']) if r['unit'] else ''}{mark}"


def clip_of_files(files: Mapping[str, bytes], max_tracks: int = 2) -> Clip:
    """The clip of a bundle's members: its replayable traces in the kind's order (the first
    ``max_tracks``), its robot.xml, and the caption from its manifest and result."""
    from app.jobs.registry import KINDS
    from app.results.replay import replay_tracks

    if "robot.xml" not in files:
        raise RenderError("not a gaitmend bundle (no robot.xml)")
    manifest = json.loads(files["manifest.json"]) if "manifest.json" in files else {}
    summary = json.loads(files["result.json"]) if "result.json" in files else None
    kind = KINDS.get(manifest.get("kind", ""))
    traces = {}
    for name, data in files.items():
        if name.startswith("trajectories/") and name.endswith(".npz"):
            tr = dict(np.load(io.BytesIO(data)))
            if "qpos" in tr and "time_s" in tr and len(tr["time_s"]) > 1:
                traces[name[len("trajectories/"):-4]] = tr
    if not traces:
        raise RenderError("the bundle has no replayable trajectories (none with qpos)")
    tracks = replay_tracks(kind, sorted(traces))[:max_tracks]
    return Clip(files["robot.xml"].decode(), {t.name: traces[t.name] for t in tracks}, tracks,
                caption_lines(kind, manifest.get("spec"), summary))


# -- rendering ----------------------------------------------------------------------------------------

def gl_backend() -> str:
    """The software-OpenGL route: MUJOCO_GL if it names egl or osmesa, else egl."""
    gl = os.environ.get("MUJOCO_GL", "").strip().lower()
    return gl if gl in GL_PACKAGES else "egl"


def _gl_context(width: int, height: int):
    backend = gl_backend()
    try:
        if backend == "osmesa":
            from mujoco.osmesa import GLContext
        else:
            from mujoco.egl import GLContext
        ctx = GLContext(width, height)
        ctx.make_current()
        return ctx
    except Exception as e:  # noqa: BLE001  (ImportError, OSError, GL errors: all mean "no OpenGL here")
        raise RenderError(f"no offscreen OpenGL ({backend}): {type(e).__name__}: {e}. Install the Debian "
                          f"package(s) {GL_PACKAGES[backend]} (scripts/test.sh does), or set MUJOCO_GL=osmesa "
                          f"with {GL_PACKAGES['osmesa']}") from None


class Panels:
    """One offscreen renderer drawing each trace's robot in its own panel, side by side,
    with the same camera placed relative to that robot. The context is made current in
    the calling thread: make and use one Panels per thread."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, n: int, camera: str = "follow"):
        if camera not in CAMERAS:
            raise ValueError(f"camera: one of {', '.join(CAMERAS)}; got {camera!r}")
        self.model, self.n, self.camera = model, n, camera
        self.pw, self.h = width // n, height
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), self.pw)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), self.h)
        self.ctx = _gl_context(self.pw, self.h)
        self.scene = mujoco.MjvScene(model, maxgeom=10000)
        self.con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.con)
        self.opt, self.pert = mujoco.MjvOption(), mujoco.MjvPerturb()
        self.rect = mujoco.MjrRect(0, 0, self.pw, self.h)
        self.data = mujoco.MjData(model)
        self.rgb = np.empty((self.h, self.pw, 3), np.uint8)
        free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
        self.root = int(model.jnt_bodyid[free[0]]) if free.size else 1
        self.cam = mujoco.MjvCamera()
        self.cam.type = mujoco.mjtCamera.mjCAMERA_FREE

    def aim(self, qpos_paths: list[np.ndarray]) -> None:
        """Camera distance from the robot's size; ``fixed`` looks at the middle of the paths."""
        roots = []
        for q in qpos_paths:
            pts = []
            for qp in (q[0], q[len(q) // 2], q[-1]):
                self.data.qpos[:] = qp
                mujoco.mj_kinematics(self.model, self.data)
                pts.append(self.data.xpos[self.root].copy())
            roots.append(np.array(pts))
        self.data.qpos[:] = qpos_paths[0][0]
        mujoco.mj_kinematics(self.model, self.data)
        sub = [b for b in range(self.model.nbody) if self._in_robot(b)] or list(range(self.model.nbody))
        size = max(0.05, float(np.linalg.norm(self.data.xpos[sub] - self.data.xpos[self.root], axis=1).max()))
        span = max(float(np.ptp(np.concatenate(roots)[:, :2], axis=0).max()), 0.0)
        self.centre = np.concatenate(roots).mean(axis=0)
        self.cam.distance = 3.2 * size + (0.9 * span if self.camera == "fixed" else 0.0)
        self.cam.azimuth, self.cam.elevation = 135.0, -22.0

    def _in_robot(self, b: int) -> bool:
        """Whether body ``b`` is the robot's base or below it (not the world's props)."""
        while b > 0:
            if b == self.root:
                return True
            b = int(self.model.body_parentid[b])
        return False

    def frame(self, qpos_rows: list[np.ndarray]) -> np.ndarray:
        """One video frame (height, width, 3): each qpos row drawn in its panel."""
        panels = []
        for qp in qpos_rows:
            self.data.qpos[:] = qp
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_camlight(self.model, self.data)
            self.cam.lookat[:] = self.data.xpos[self.root] if self.camera == "follow" else self.centre
            mujoco.mjv_updateScene(self.model, self.data, self.opt, self.pert, self.cam,
                                   mujoco.mjtCatBit.mjCAT_ALL, self.scene)
            mujoco.mjr_render(self.rect, self.scene, self.con)
            mujoco.mjr_readPixels(self.rgb, None, self.rect, self.con)
            panels.append(np.flipud(self.rgb).copy())
        return np.concatenate(panels, axis=1)

    def close(self) -> None:
        self.con.free()
        self.ctx.free()


def frame_indices(traces: Mapping[str, Mapping[str, np.ndarray]], fps: float,
                  seconds: float | None = None) -> tuple[dict[str, np.ndarray], int]:
    """The sample of each trace shown at each frame, on one clock from the gait's start
    (time 0, or the trace's first sample) to the longest trace's end (or ``seconds``); a
    trace that ended holds its last pose."""
    start = min(max(float(np.asarray(tr["time_s"])[0]), 0.0) for tr in traces.values())
    end = max(float(np.asarray(tr["time_s"])[-1]) for tr in traces.values())
    if seconds is not None:
        end = min(end, start + seconds)
    clock = start + np.arange(max(1, int(round((end - start) * fps)) + 1)) / fps
    out = {name: np.clip(np.searchsorted(np.asarray(tr["time_s"]), clock - 1e-9), 0, len(tr["time_s"]) - 1)
           for name, tr in traces.items()}
    return out, len(clock)


# -- captions ------------------------------------------------------------------------------------------

def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow before 10.1 has one bitmap size
        return ImageFont.load_default()


def overlay(frame: np.ndarray, labels: list[str], caption: list[str], t: float) -> np.ndarray:
    """The panels' labels and the clock on top, the caption on a dark band at the bottom."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img, "RGBA")
    h, w = frame.shape[:2]
    size = max(8, h // 30)
    widest = max([draw.textlength(line, font=_font(size)) for line in caption] + [1.0])
    size = max(8, min(size, int(size * (w - size) / widest)))  # a long caption shrinks to fit the width
    font = _font(size)
    pw = w // max(1, len(labels))
    for k, label in enumerate(labels):
        draw.rectangle((k * pw, 0, k * pw + pw, int(1.6 * size)), fill=(0, 0, 0, 110))
        draw.text((k * pw + size // 2, size // 4), label, fill=(255, 255, 255, 255), font=font)
    clock = f"t = {t:5.2f} s"
    draw.text((w - size // 2 - draw.textlength(clock, font=font), size // 4), clock, fill=(255, 255, 255), font=font)
    band = int((len(caption) + 0.4) * 1.3 * size)
    draw.rectangle((0, h - band, w, h), fill=(0, 0, 0, 150))
    for i, line in enumerate(caption):
        draw.text((size // 2, h - band + int((0.2 + 1.3 * i) * size)), line, fill=(255, 255, 255), font=font)
    return np.asarray(img)


# -- encoding --------------------------------------------------------------------------------------------

def _even(n: int) -> int:
    return max(2, n - n % 2)


def render_model(xml: str) -> mujoco.MjModel:
    """The simulated model dressed for the camera only (the same bodies and geoms): a
    checker floor scaled to the robot, so a followed robot is seen to move; a far plane far
    enough that the floor reaches the horizon; shadows and anti-aliasing a software
    rasteriser draws in a fraction of a second (no multisampling, 2048 px shadow map)."""
    spec = mujoco.MjSpec.from_string(xml)
    planes = [g for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE and not g.material]
    if planes:
        spec.add_texture(name="gaitmend_floor", type=mujoco.mjtTexture.mjTEXTURE_2D,
                         builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.82, 0.84, 0.86],
                         rgb2=[0.68, 0.70, 0.73], width=256, height=256)
        mat = spec.add_material(name="gaitmend_floor")
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "gaitmend_floor"
        mat.texuniform = True
        for g in planes:
            g.material, g.rgba = "gaitmend_floor", [1.0, 1.0, 1.0, 1.0]
    model = spec.compile()
    if planes:
        model.mat_texrepeat[model.nmat - 1] = 2.0 / max(float(model.stat.extent), 1e-3)  # squares of extent / 4
    model.vis.map.zfar = max(float(model.vis.map.zfar), 200.0)
    model.vis.quality.offsamples = 0
    model.vis.quality.shadowsize = min(int(model.vis.quality.shadowsize), 2048)
    return model


def render_frames(clip: Clip, width: int, height: int, fps: float, camera: str = "follow",
                  seconds: float | None = None, captions: bool = True):
    """Yield the clip's frames (height, width, 3) uint8, each panel ``width / n`` wide."""
    model = render_model(clip.model_xml)
    names = [t.name for t in clip.tracks]
    idx, n = frame_indices(clip.traces, fps, seconds)
    qpos = {k: np.asarray(clip.traces[k]["qpos"]) for k in names}
    panels = Panels(model, width, height, len(names), camera)
    try:
        panels.aim([qpos[k] for k in names])
        t0 = min(max(float(np.asarray(clip.traces[k]["time_s"])[0]), 0.0) for k in names)
        for i in range(n):
            img = panels.frame([qpos[k][idx[k][i]] for k in names])
            yield overlay(img, [t.label for t in clip.tracks], clip.caption, t0 + i / fps) if captions else img
    finally:
        panels.close()


def write_mp4(clip: Clip, out: Path, width: int = WIDTH, height: int = HEIGHT, fps: int = FPS,
              camera: str = "follow", seconds: float | None = None) -> dict[str, Any]:
    """Render and encode the clip as H.264 (yuv420p, plays everywhere) at ``fps``; written
    to a part file and renamed. Returns {"path", "frames", "width", "height", "fps", "seconds"}."""
    import av

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    width, height = _even(width - width % (2 * len(clip.tracks))), _even(height)
    part = out.with_name(out.name + ".part")
    frames = 0
    try:
        with av.open(str(part), mode="w", format="mp4") as container:
            stream = container.add_stream("libx264", rate=Fraction(fps))
            stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
            stream.options = {"crf": "23", "preset": "veryfast"}
            for img in render_frames(clip, width, height, fps, camera, seconds):
                for packet in stream.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                    container.mux(packet)
                frames += 1
            for packet in stream.encode():
                container.mux(packet)
        os.replace(part, out)
    finally:
        part.unlink(missing_ok=True)
    return {"path": str(out), "frames": frames, "width": width, "height": height, "fps": fps,
            "seconds": frames / fps}


def write_thumbnail(clip: Clip, out: Path, width: int = THUMB_WIDTH, height: int = THUMB_HEIGHT,
                    fps: int = THUMB_FPS, seconds: float = THUMB_SECONDS) -> Path:
    """A small looping animated WebP of the first trace (no captions), its whole run
    played in ``seconds``."""
    from PIL import Image

    first = Clip(clip.model_xml, {clip.tracks[0].name: clip.traces[clip.tracks[0].name]}, clip.tracks[:1], [])
    tr = first.traces[clip.tracks[0].name]
    span = float(np.asarray(tr["time_s"])[-1]) - max(float(np.asarray(tr["time_s"])[0]), 0.0)
    sim_fps = fps * seconds / max(span, 1e-6)  # sample the run so it plays in `seconds`
    images = [Image.fromarray(img) for img in render_frames(first, _even(width), _even(height), sim_fps,
                                                             captions=False)]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    part = out.with_name(out.name + ".part")
    images[0].save(part, format="WEBP", save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0,
                   quality=60, method=4)
    os.replace(part, out)
    return out


def probe(path: Path) -> dict[str, Any]:
    """What a decoder reads from a video file: frames decoded, size, duration, codec."""
    import av

    with av.open(str(path)) as c:
        s = c.streams.video[0]
        frames = sum(1 for _ in c.decode(s))
        return {"frames": frames, "width": s.codec_context.width, "height": s.codec_context.height,
                "fps": float(s.average_rate) if s.average_rate else None, "codec": s.codec_context.name,
                "seconds": float(c.duration / av.time_base) if c.duration else None}


# -- kept with the bundle ------------------------------------------------------------------------------

MEDIA = {"video": ("media/walk.mp4", "video/mp4"), "thumbnail": ("media/thumbnail.webp", "image/webp")}


def member(bundle: Path, name: str) -> bytes | None:
    """A member of a bundle zip, or None when it has none of that name."""
    with zipfile.ZipFile(bundle) as z:
        return z.read(name) if name in z.namelist() else None


def add_member(bundle: Path, name: str, data: bytes) -> None:
    """Keep ``data`` in the bundle zip as ``name``: a copy with the member added (or
    replaced) is written beside it and renamed over it, so a download in progress reads
    the old file to its end and a reader never sees half a zip."""
    bundle = Path(bundle)
    part = bundle.with_name(bundle.name + ".media.part")
    try:
        with zipfile.ZipFile(bundle) as src, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as dst:
            for info in src.infolist():
                if info.filename != name:
                    dst.writestr(info, src.read(info))
            dst.writestr(name, data, compress_type=zipfile.ZIP_STORED)  # MP4 and WebP are compressed already
        os.replace(part, bundle)
    finally:
        part.unlink(missing_ok=True)


def render_into_bundle(bundle: Path, what: str) -> bytes:
    """Render the bundle's video or thumbnail (``what``: a key of MEDIA) at the defaults,
    keep it in the bundle, and return it; an existing one is returned as it is."""
    name, _ = MEDIA[what]
    found = member(bundle, name)
    if found is not None:
        return found
    import tempfile

    clip = clip_of_files(bundle_files(bundle))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / Path(name).name
        if what == "video":
            write_mp4(clip, out)
        else:
            write_thumbnail(clip, out)
        data = out.read_bytes()
    add_member(bundle, name, data)
    return data


def main(argv: list[str] | None = None) -> int:
    """``python -m app.results.video BUNDLE video|thumbnail``: what the API runs in a
    child process (rendering holds a CPU and an OpenGL context for seconds to minutes; the
    server's own process stays free). Exit 0 with the member kept in the bundle; 3 when
    there is nothing to render or no OpenGL, with the reason on stderr."""
    import sys

    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2 or args[1] not in MEDIA:
        print(f"usage: python -m app.results.video BUNDLE {'|'.join(MEDIA)}", file=sys.stderr)
        return 2
    try:
        render_into_bundle(Path(args[0]), args[1])
    except RenderError as e:
        print(str(e), file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

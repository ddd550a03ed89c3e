"""`gaitmend video JOB|BUNDLE`: an MP4 of the recovered gait beside its baseline."""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Optional

import typer

from app.cli.client import ServerOpt, TokenOpt, _client
from app.cli.common import cli, err, fail


def _bundle_of(target: str, server: Optional[str], token: Optional[str], tmp: Path) -> Path:
    path = Path(target)
    if path.exists():
        return path.parent if path.name == "manifest.json" else path
    if path.suffix == ".zip" or "/" in target or target.startswith("."):
        fail(f"no such bundle file or folder: {target} (a job id has no '/' or '.zip')")
    with _client(server, token) as c:
        return c.job(target).bundle(tmp)


@cli.command()
def video(
    target: str = typer.Argument(..., metavar="JOB|BUNDLE", help="a job id on --server, or a bundle (.zip or folder)"),
    out: Path = typer.Option(Path("walk.mp4"), "--out", help="the MP4 to write"),
    camera: str = typer.Option("follow", "--camera", help="follow: the camera moves with each robot; "
                               "fixed: one view of the whole walk"),
    width: int = typer.Option(1280, min=64, max=3840, help="frame width in pixels (the panels share it)"),
    height: int = typer.Option(720, min=64, max=2160, help="frame height in pixels"),
    fps: int = typer.Option(30, min=1, max=120, help="frames per second (simulated time plays in real time)"),
    seconds: Optional[float] = typer.Option(None, min=0.1, help="only the first SECONDS of the walk"),
    thumbnail: Optional[Path] = typer.Option(None, "--thumbnail", help="also write a small animated WebP here"),
    server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt,
    as_json: bool = typer.Option(False, "--json", help="print what was written as JSON"),
):
    """Render the recovered gait and its baseline side by side (MuJoCo's offscreen
    renderer, software OpenGL: no display or GPU needed), captioned with the damage, the
    target and the distance, as H.264 MP4 (default 1280x720 at 30 frames per second)."""
    from app.results.video import CAMERAS, RenderError, bundle_files, clip_of_files, write_mp4, write_thumbnail

    if camera not in CAMERAS:
        fail(f"--camera: one of {', '.join(CAMERAS)}; got {camera!r}")
    with tempfile.TemporaryDirectory() as tmp:
        bundle = _bundle_of(target, server, token, Path(tmp))
        t0 = time.monotonic()
        try:
            clip = clip_of_files(bundle_files(bundle))
            info = write_mp4(clip, out, width, height, fps, camera=camera, seconds=seconds)
            if thumbnail is not None:
                info["thumbnail"] = str(write_thumbnail(clip, thumbnail))
        except (RenderError, OSError, KeyError, ValueError) as e:
            fail(f"cannot render {target}: {e}", code=1)
    info["render_s"] = round(time.monotonic() - t0, 2)
    if as_json:
        print(json.dumps(info))
        return
    print(out)
    err.print(f"{info['frames']} frames, {info['width']}x{info['height']} at {fps} fps ({info['seconds']:.1f} s of "
              f"video) of {', '.join(t.label for t in clip.tracks)}; rendered in {info['render_s']:.1f} s",
              highlight=False)

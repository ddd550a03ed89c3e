"""Videos: `gaitmend video` writes a playable MP4 (read back by a decoder: frame count,
size, duration) for a recovery and an energy job, with MuJoCo's offscreen renderer on
software OpenGL; the API serves the video and the thumbnail, rendered on the first request
and kept in the bundle."""

from __future__ import annotations

import json
import sys
import zipfile

import httpx
import numpy as np
import pytest

import gaitmend
from app.results.video import RenderError, bundle_files, clip_of_files, probe


def gaitmend_cli(*args):
    from typer.testing import CliRunner

    from app.cli import cli

    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def _expected_frames(bundle, fps: float, tracks: int = 2) -> int:
    """Frames of the common clock: the gait's start to the longest shown trace's end."""
    clip = clip_of_files(bundle_files(bundle))
    times = [np.asarray(clip.traces[t.name]["time_s"]) for t in clip.tracks[:tracks]]
    start = min(max(float(t[0]), 0.0) for t in times)
    return int(round((max(float(t[-1]) for t in times) - start) * fps)) + 1


@pytest.mark.parametrize("kind", ["recovery", "energy"])
def test_video_command_writes_a_playable_mp4(kind, bundles, finished, tmp_path, served):
    out = tmp_path / f"{kind}.mp4"
    r = gaitmend_cli("video", str(bundles[kind]), "--out", str(out), "--width", "320", "--height", "180",
                     "--fps", "10", "--thumbnail", str(tmp_path / "t.webp"), "--json")
    assert r.exit_code == 0, r.output
    info = json.loads(r.stdout.strip().splitlines()[-1])
    got = probe(out)
    n = _expected_frames(bundles[kind], 10)
    assert (got["frames"], got["width"], got["height"], got["codec"]) == (n, 320, 180, "h264"), got
    assert got["fps"] == 10 and got["seconds"] == pytest.approx(n / 10, abs=0.11)
    assert info["frames"] == n and info["render_s"] > 0
    from PIL import Image

    with Image.open(tmp_path / "t.webp") as im:
        assert im.format == "WEBP" and im.is_animated and im.n_frames > 4 and im.size == (240, 136)
    # a job id on the server: its bundle is fetched, then rendered here (the camera fixed this time)
    r = gaitmend_cli("video", finished[kind].id[:10], "--out", str(tmp_path / "by-id.mp4"), "--width", "160",
                     "--height", "96", "--fps", "5", "--camera", "fixed", "--server", served[0])
    assert r.exit_code == 0, r.output
    assert probe(tmp_path / "by-id.mp4")["frames"] == _expected_frames(bundles[kind], 5)


def test_the_api_serves_the_video_and_thumbnail_kept_with_the_bundle(client, finished, tmp_path):
    job = finished["energy"]  # its physics trace is half a second: a short video at the full size
    r = httpx.get(f"{client.server}/api/jobs/{job.id}/video", timeout=600)
    assert r.status_code == 200 and r.headers["content-type"] == "video/mp4", r.text[:300]
    (tmp_path / "api.mp4").write_bytes(r.content)
    got = probe(tmp_path / "api.mp4")
    assert (got["width"], got["height"], got["fps"]) == (1280, 720, 30) and got["frames"] > 1
    assert job.video(tmp_path / "again.mp4").read_bytes() == r.content  # kept: the same file, not a new render
    t = httpx.get(f"{client.server}/api/jobs/{job.id}/thumbnail", timeout=600)
    assert t.status_code == 200 and t.headers["content-type"] == "image/webp" and t.content[8:12] == b"WEBP"
    with zipfile.ZipFile(job.bundle(tmp_path)) as z:  # the bundle carries both from now on
        assert z.read("media/walk.mp4") == r.content and z.read("media/thumbnail.webp") == t.content
        assert "manifest.json" in z.namelist()
    assert gaitmend.open_bundle(tmp_path / f"gaitmend-{job.id}.zip").video  # still a bundle
    assert job.info["links"]["video"] == f"/api/jobs/{job.id}/video"
    missing = httpx.get(f"{client.server}/api/jobs/{'0' * 32}/video")
    assert missing.status_code == 404 and missing.json()["errors"][0]["field"] == "id"


def test_no_opengl_is_a_clear_error(bundles, monkeypatch):
    """Without the OpenGL library the route names the Debian package to install."""
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setitem(sys.modules, "mujoco.osmesa", None)  # as if libOSMesa were not installed
    from app.results.video import write_mp4

    with pytest.raises(RenderError, match="libosmesa6"):
        write_mp4(clip_of_files(bundle_files(bundles["recovery"])), bundles["recovery"].with_suffix(".mp4"),
                  64, 64, 5)

"""Replay recordings: geometry once, then only poses per frame."""

import collections
import contextlib
import io

import numpy as np
import pytest

from app.jobs.recovery.sequences import plan_hexapod
from app.jobs.recovery.run import nominal_params
from app.results.replay import _free_port, _Scene, record
from app.robots.catalog import JETHEXA
from app.robots.damage import DamageSpec
from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig


@pytest.fixture(scope="module")
def traces():
    _, model = JETHEXA.model(DamageSpec(lost_legs=(3,)))
    legs = [1, 2, 4, 5, 6]
    ev = GaitEvaluator(JETHEXA, model, plan_hexapod((3,), JETHEXA.nominal_feet_xy()),
                       SimConfig(duration_s=1.0, settle_s=0.2))
    return model, {"best": ev.trace(nominal_params(JETHEXA, legs))}


def test_geometry_is_sent_once_and_frames_only_move_bodies(traces):
    import viser

    model, tr = traces
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=_free_port(), verbose=False)
    try:
        sc = _Scene(server, model, tr, fps=25)
        ser = server.get_scene_serializer()
        setup = collections.Counter(type(m).__name__ for m in server._websock_server._broadcast_buffer.message_from_id.values())
        n_before = len(ser._messages)
        for i in range(10):
            sc.show(i)
            ser.insert_sleep(0.04)
        frame_msgs = collections.Counter(m[1]["type"] for m in ser._messages[n_before:])
    finally:
        with contextlib.redirect_stdout(io.StringIO()):
            server.stop()
    assert sc.n == 30  # (1.0 + 0.2 - 0.004) s at 25 fps
    assert any("Box" in k for k in setup) and any("Cylinder" in k for k in setup)
    # Per frame: poses of the moving bodies (and the contact markers), never geometry.
    assert set(frame_msgs) <= {"SetPositionMessage", "SetOrientationMessage", "SetWxyzMessage",
                               "SceneNodeUpdateMessage", "PointCloudMessage", "SetPropsMessage"}, frame_msgs
    assert not any("Mesh" in k or "Box" in k or "Cylinder" in k for k in frame_msgs)
    moving = model.nbody - 1
    assert sum(frame_msgs.values()) >= 10 * moving, frame_msgs


def test_record_returns_a_viser_file(traces):
    model, tr = traces
    data = record(model, tr)
    assert isinstance(data, bytes) and len(data) > 10_000
    assert np.isfinite(tr["best"]["qpos"]).all()


def _messages(data: bytes) -> list[dict]:
    """The messages of a .viser recording (zstd over an 8-byte length and msgpack metadata)."""
    import msgspec
    import zstandard

    inner = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=int.from_bytes(data[:8], "little"))
    n = int.from_bytes(inner[:8], "little")
    return [m for _, m in msgspec.msgpack.decode(inner[8:8 + n])["messages"]]


def test_one_scene_per_track_each_robot_alone(traces):
    """The bundle's replay.viser holds the first track's robot alone, replay/<name>.viser each
    other's; no dynamic shadows and no environment map (what a software renderer plays
    smoothly); README rows name the runs."""
    from app.jobs.base import ReplayTrack
    from app.results.replay import record_scenes, scene_rows

    model, tr = traces
    both = {"best": tr["best"], "base line": tr["best"]}
    tracks = [ReplayTrack("best", "recovered gait", "method", 0), ReplayTrack("base line", "nominal tripod", "baseline", 1)]
    scenes = record_scenes(model, both, tracks)
    assert list(scenes) == ["replay.viser", "replay/base_line.viser"]
    for path, own, other in (("replay.viser", "best", "base line"), ("replay/base_line.viser", "base line", "best")):
        msgs = _messages(scenes[path])
        names = {m["name"] for m in msgs if isinstance(m.get("name"), str)}
        assert any(n.startswith(f"/world/{own}/") for n in names), path
        assert not any(n.startswith(f"/world/{other}/") for n in names), path
        lights = [m for m in msgs if m.get("type") == "EnableLightsMessage"]
        assert lights and lights[-1]["cast_shadow"] is False, lights
        # nor the client's default environment map (per-pixel image-based lighting): a
        # hemisphere light shades the faces instead
        env = [m for m in msgs if m.get("type") == "EnvironmentMapMessage"]
        assert env and env[-1]["hdri_data"] is None, env
        assert any(m.get("type") == "HemisphereLightMessage" for m in msgs), path
    rows = scene_rows(tracks)
    assert set(rows) == set(scenes) and "nominal tripod alone" in rows["replay/base_line.viser"]

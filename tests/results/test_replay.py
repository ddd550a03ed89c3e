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

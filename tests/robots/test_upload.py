"""Uploaded robots (issue 23): third-party models load through the whole defence, the
hostile suite is refused at the pre-parse or in the confined compile with nothing read
from the host, and `gaitmend robot add|list|delete` store them (exit 2 on a refusal,
nothing stored)."""

from __future__ import annotations

import json
import shutil
import sys
import uuid
from pathlib import Path

import pytest
from typer.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parent))
import hostile_cases as hc  # noqa: E402
import legged_models as lm_  # noqa: E402

from app.cli import cli  # noqa: E402
from app.robots.upload import RefusedUpload, Upload, from_dir, from_zip, prepare  # noqa: E402
from app.robots.upload.mjcf import Sanitised  # noqa: E402
from app.robots.upload.sandbox import compile_confined  # noqa: E402


@pytest.fixture
def secret(tmp_path):
    """Host files an upload must never read: each holds a marker that must never show up."""
    marker = f"GAITMEND-SECRET-{uuid.uuid4().hex}"
    folder = tmp_path / "host"
    folder.mkdir()
    for ext in ("xml", "stl", "png", "skn", "dtd"):
        (folder / f"secret.{ext}").write_text(f"<mujoco model='{marker}'/>" if ext == "xml" else marker)
    return folder / "secret", folder / "absent", marker


def _refusal(case: hc.Case, files: dict[str, bytes]) -> str:
    with pytest.raises(RefusedUpload) as e:
        upload = from_zip(case.archive) if case.archive is not None else Upload("model.xml", files)
        prepare(upload)
    return str(e.value)


def test_the_hostile_suite_is_refused_and_reads_nothing(secret, tmp_path):
    path, missing, marker = secret
    all_cases = hc.cases(path.parent)
    assert len(all_cases) >= 25
    for case in all_cases:
        msg = _refusal(case, hc.fill(case.files, path, missing))
        assert case.expect.lower() in msg.lower(), (case.name, msg)
        assert marker not in msg, case.name
        if case.host_path:  # the same words whether the host path exists or not
            other = _refusal(case, hc.fill(case.files, missing, missing))
            assert msg.replace(str(path), "<P>") == other.replace(str(missing), "<P>"), (case.name, msg, other)


@pytest.mark.parametrize("ext, xml", [
    ("png", '<asset><texture name="t" type="2d" file="{P}.png"/></asset>'),
    ("stl", '<asset><mesh name="m" file="{P}.stl"/></asset>'),
    ("xml", '<include file="{P}.xml"/>'),
])
def test_even_past_the_pre_parse_the_confined_compile_reads_no_host_file(secret, ext, xml):
    """Second layer: a model handed to the sandbox with a host path in it (the pre-parse
    bypassed) is refused with the same words for an existing and a missing file, and the
    secret never comes back: the compiling process may open no file at all (Landlock)."""
    path, missing, marker = secret
    messages = []
    for p in (path, missing):
        model = Sanitised(xml=hc.legged(xml.replace("{P}", str(p))).decode(), assets={})
        with pytest.raises(RefusedUpload) as e:
            answer = compile_confined(model, None, None)
            if not answer["sandbox"]["landlock"]:
                pytest.skip("this kernel has no Landlock: the pre-parse is the only file guard here")
        messages.append(str(e.value).replace(str(p), "<P>"))
        assert marker not in str(e.value)
    assert messages[0] == messages[1], messages


def test_the_confined_compile_stops_a_memory_bomb_that_got_past_the_pre_parse():
    model = Sanitised(xml=hc.legged('<size memory="8G"/>').decode(), assets={})
    with pytest.raises(RefusedUpload, match="memory|allocate"):
        compile_confined(model, None, None)


def test_a_scene_including_common_files_loads_dm_control_quadruped(tmp_path):
    path = lm_.dm_control_quadruped()
    assert path is not None, "dm_control is missing: the test extra brings it (pip install -e '.[test]')"
    shutil.copytree(path.parent / "common", tmp_path / "common")
    prepared = prepare(from_dir(path, tmp_path))
    assert prepared.detected and len(prepared.legs.legs) == 4
    assert "<include" not in prepared.xml and prepared.assets == {}  # inlined; only textures built in
    assert prepared.stats["hfields"] == 1 and prepared.stats["actuators"] == 12
    assert prepared.sandbox["cpu_s"] > 0
    # the same as one zip under a top folder
    buf = hc.zip_of([("quadruped/quadruped.xml", path.read_bytes())]
                    + [(f"quadruped/common/{f.name}", f.read_bytes()) for f in (tmp_path / "common").glob("*.xml")])
    assert prepare(from_zip(buf)).content_hash == prepared.content_hash


def test_a_robot_built_here_uploads_with_its_meshes_and_given_legs(tmp_path):
    """A model with an STL mesh and a PNG texture in sub-folders, and an explicit leg map."""
    import mujoco

    spec = lm_.build(lm_.OCTOPOD)
    model = spec.compile()
    from app.robots.detect import detect_legs

    legs = detect_legs(model).to_json()
    legs["legs"][0]["name"] = "front_left"
    xml = spec.to_xml().replace("<asset>", "<asset>", 1)
    stl = _stl_box()
    xml = xml.replace("</mujoco>", '<asset><mesh name="shell" file="./meshes/shell.stl"/>'
                      '<texture name="skin" type="2d" file="textures/skin.png"/></asset></mujoco>')
    (tmp_path / "meshes").mkdir()
    (tmp_path / "textures").mkdir()
    (tmp_path / "meshes" / "shell.stl").write_bytes(stl)
    (tmp_path / "textures" / "skin.png").write_bytes(hc.png(8, 8))
    (tmp_path / "robot.xml").write_text(xml)
    prepared = prepare(from_dir(tmp_path / "robot.xml", tmp_path), legs=json.dumps(legs))
    assert not prepared.detected and prepared.legs.legs[0].name == "front_left"
    assert sorted(prepared.assets) == ["meshes/shell.stl", "textures/skin.png"]
    assert 'file="meshes/shell.stl"' in prepared.xml  # rewritten to the normalised name
    assert mujoco.MjModel.from_xml_string(prepared.xml, prepared.assets).nmesh == 1


def _stl_box() -> bytes:
    import struct

    tris = [((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((0, 0, 0), (0, 0, 1), (1, 0, 0)), ((0, 0, 0), (0, 1, 0), (0, 0, 1)),
            ((1, 0, 0), (0, 0, 1), (0, 1, 0))]
    out = b"\0" * 80 + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *(0.05 * c for c in v)) for v in t) + b"\0\0"
    return out


# -- the CLI ------------------------------------------------------------------------------------

def _cli(tmp_path, *args):
    env = {"GAITMEND_DATA_DIR": str(tmp_path / "data"), "GAITMEND_DATABASE_URL": ""}
    return CliRunner().invoke(cli, ["robot", *args], env=env, catch_exceptions=False)


def test_cli_adds_lists_and_deletes_the_gymnasium_ant(tmp_path):
    ant = lm_.gymnasium_ant()
    assert ant is not None, "gymnasium is missing: the test extra brings it (pip install -e '.[test]')"
    r = _cli(tmp_path, "add", str(ant), "--json")
    assert r.exit_code == 0, r.output
    robot = json.loads(r.stdout.strip().splitlines()[-1])
    assert len(robot["id"]) == 32 and robot["created"]
    assert sorted(tuple(l["joints"]) for l in robot["legs"]["legs"]) == [(f"hip_{i}", f"ankle_{i}") for i in range(1, 5)]
    assert all({"name", "joints"} <= set(l) for l in robot["legs"]["legs"])
    folder = tmp_path / "data" / "robots" / robot["id"]
    assert (folder / "model.xml").is_file()
    again = json.loads(_cli(tmp_path, "add", str(ant), "--json").stdout.strip().splitlines()[-1])
    assert again["id"] == robot["id"] and not again["created"]  # immutable: same content, same robot
    listed = json.loads(_cli(tmp_path, "list", "--json").stdout.strip().splitlines()[-1])
    assert [x["id"] for x in listed] == [robot["id"]]
    assert _cli(tmp_path, "delete", robot["id"]).exit_code == 0
    assert not folder.exists()
    assert json.loads(_cli(tmp_path, "list", "--json").stdout.strip().splitlines()[-1]) == []
    assert _cli(tmp_path, "delete", robot["id"]).exit_code == 2


def test_cli_refuses_with_exit_2_and_stores_nothing(tmp_path, secret):
    path, missing, marker = secret
    by_name = {c.name: c for c in hc.cases(path.parent)}
    for name in ("include-absolute", "texture-absolute", "entity-expansion", "size-memory", "zip-slip", "no-legs"):
        case = by_name[name]
        up = tmp_path / name
        up.mkdir()
        if case.archive is not None:
            (up / "robot.zip").write_bytes(case.archive)
            target = up / "robot.zip"
        else:
            for k, v in hc.fill(case.files, path, missing).items():
                (up / k).write_bytes(v)
            target = up / "model.xml"
        r = _cli(tmp_path, "add", str(target), "--assets", str(up)) if case.archive is None else _cli(tmp_path, "add", str(target))
        assert r.exit_code == 2, (name, r.output)
        assert "refused" in r.output and marker not in r.output
    data = tmp_path / "data" / "robots"
    assert not data.exists() or not any(data.iterdir())
    assert json.loads(_cli(tmp_path, "list", "--json").stdout.strip().splitlines()[-1]) == []


def test_the_wall_clock_limit_kills_a_compile_that_runs_long():
    import dataclasses

    from app.robots.upload import LIMITS

    model = Sanitised(xml=hc.legged().decode(), assets={})
    with pytest.raises(RefusedUpload, match="took longer than"):
        compile_confined(model, None, None, dataclasses.replace(LIMITS, compile_wall_s=0.05))

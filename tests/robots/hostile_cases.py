"""Hostile uploads (issue 23, item 3): each case is an upload that must be refused with a
message naming what was refused, nothing stored and nothing read from the host. Cases
that name a host path come in pairs, an existing secret file and a missing one beside it,
whose messages must be identical once the path itself is taken out."""

from __future__ import annotations

import dataclasses
import io
import stat
import struct
import zipfile
import zlib
from pathlib import Path

LEGGED = """<mujoco model="bot">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 .1"/>
    <body name="trunk" pos="0 0 .3"><freejoint/>
      <geom type="box" size=".2 .1 .03"/>
      <body name="fl" pos=".2 .1 0"><joint name="fl_hip" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/>
        <body pos="0 0 -.2"><joint name="fl_knee" axis="0 1 0"/><geom name="fl_foot" type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/></body></body>
      <body name="fr" pos=".2 -.1 0"><joint name="fr_hip" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/>
        <body pos="0 0 -.2"><joint name="fr_knee" axis="0 1 0"/><geom name="fr_foot" type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/></body></body>
      <body name="bl" pos="-.2 .1 0"><joint name="bl_hip" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/>
        <body pos="0 0 -.2"><joint name="bl_knee" axis="0 1 0"/><geom name="bl_foot" type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/></body></body>
      <body name="br" pos="-.2 -.1 0"><joint name="br_hip" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/>
        <body pos="0 0 -.2"><joint name="br_knee" axis="0 1 0"/><geom name="br_foot" type="capsule" fromto="0 0 0 0 0 -.2" size=".02"/></body></body>
    </body>
  </worldbody>
  %s
</mujoco>"""


def legged(extra: str = "", world: str = "") -> bytes:
    """A small valid quadruped, with extra top-level elements and extra world elements."""
    return (LEGGED % extra).replace("<worldbody>", "<worldbody>" + world, 1).encode()


def png(width: int, height: int, pixels: bool = True) -> bytes:
    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + b"\x80" * (3 * width) for _ in range(height)) if pixels else b""
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def zip_of(entries: list[tuple[str, bytes]], link: str | None = None) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in entries:
            z.writestr(name, data)
        if link:
            info = zipfile.ZipInfo(link)
            info.external_attr = (stat.S_IFLNK | 0o777) << 16
            z.writestr(info, "/etc/passwd")
    return buf.getvalue()


@dataclasses.dataclass(frozen=True)
class Case:
    name: str
    files: dict[str, bytes]  # the upload; "model.xml" is the model unless archive is set
    expect: str  # words the refusal must contain
    archive: bytes | None = None
    host_path: bool = False  # files name {SECRET}: run again with {MISSING}, same message


def cases(secret_dir: Path) -> list[Case]:
    """Every hostile upload; {SECRET} and {MISSING} in the files stand for host paths."""
    S = "{SECRET}"
    deep = "<body>" * 70 + "</body>" * 70
    many = "".join(f'<geom size=".01" pos="0 0 {i * 1e-3:.3f}"/>' for i in range(21000))
    bomb = ('<?xml version="1.0"?><!DOCTYPE m [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">'
            '<!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;">]><mujoco model="&c;"/>').encode()
    out = [
        Case("include-absolute", {"model.xml": legged(f'<include file="{S}.xml"/>')}, "absolute paths", host_path=True),
        Case("include-dotdot", {"model.xml": legged('<include file="../../etc/passwd"/>')}, "'..' is refused"),
        Case("include-uri", {"model.xml": legged(f'<include file="file://{S}.xml"/>')}, "URI", host_path=True),
        Case("include-not-uploaded", {"model.xml": legged('<include file="common/missing.xml"/>')}, "not one of the uploaded"),
        Case("include-cycle", {"model.xml": legged('<include file="a.xml"/>'),
                               "a.xml": b'<mujoco><include file="b.xml"/></mujoco>',
                               "b.xml": b'<mujoco><include file="a.xml"/></mujoco>'}, "nested deeper"),
        Case("mesh-absolute", {"model.xml": legged(f'<asset><mesh name="m" file="{S}.stl"/></asset>')}, "absolute paths", host_path=True),
        Case("hfield-absolute", {"model.xml": legged(f'<asset><hfield name="h" file="{S}.png"/></asset>')}, "absolute paths", host_path=True),
        Case("texture-absolute", {"model.xml": legged(f'<asset><texture name="t" type="2d" file="{S}.png"/></asset>')}, "absolute paths", host_path=True),
        Case("texture-cube-side", {"model.xml": legged(f'<asset><texture name="t" type="cube" fileright="{S}.png"/></asset>')}, "absolute paths", host_path=True),
        Case("skin-absolute", {"model.xml": legged(f'<deformable><skin name="s" file="{S}.skn"/></deformable>')}, "absolute paths", host_path=True),
        Case("meshdir", {"model.xml": legged(f'<compiler meshdir="{secret_dir}"/>')}, "meshdir> is refused"),
        Case("texturedir", {"model.xml": legged('<compiler texturedir="/etc"/>')}, "texturedir> is refused"),
        Case("assetdir", {"model.xml": legged('<compiler assetdir="/"/>')}, "assetdir> is refused"),
        Case("strippath", {"model.xml": legged('<compiler strippath="true"/>')}, "strippath"),
        Case("entity-expansion", {"model.xml": bomb}, "DTD"),
        Case("external-dtd", {"model.xml": f'<?xml version="1.0"?><!DOCTYPE mujoco SYSTEM "{S}.dtd"><mujoco/>'.encode()}, "DTD"),
        Case("external-entity", {"model.xml": f'<!DOCTYPE m [<!ENTITY x SYSTEM "file://{S}.xml">]><mujoco model="&x;"/>'.encode()}, "DTD"),
        Case("size-memory", {"model.xml": legged('<size memory="64G"/>')}, "memory"),
        Case("inline-hfield", {"model.xml": legged('<asset><hfield name="h" nrow="20000" ncol="20000" size="1 1 1 1"/></asset>')}, "hfield"),
        Case("replicate-count", {"model.xml": legged(world='<replicate count="100000" euler="0 0 1"><geom size=".1"/></replicate>')}, "replicate"),
        Case("replicate-nested", {"model.xml": legged(world='<replicate count="8" euler="0 0 1"><replicate count="8" euler="0 0 1"><replicate count="8" euler="0 0 1"><geom size=".1"/></replicate></replicate></replicate>')}, "multiply"),
        Case("deep-nesting", {"model.xml": legged(world=deep)}, "nested deeper"),
        Case("many-elements", {"model.xml": legged(world=many)}, "XML elements"),
        Case("plugin-extension", {"model.xml": legged('<extension><plugin plugin="mujoco.elasticity.cable"/></extension>')}, "plugins"),
        Case("plugin-instance", {"model.xml": legged(world='<body><plugin instance="x"/><geom size=".1"/></body>')}, "plugins"),
        Case("plugin-attribute", {"model.xml": legged('<asset><mesh name="m" plugin="x"/></asset>')}, "plugins"),
        Case("sub-model", {"model.xml": legged(f'<asset><model name="o" file="{S}.xml"/></asset>')}, "sub-model"),
        Case("attach", {"model.xml": legged(world='<attach model="o" prefix="a"/>')}, "attach"),
        Case("texture-builtin-huge", {"model.xml": legged('<asset><texture name="t" type="2d" builtin="flat" width="100000" height="100000"/></asset>')}, "texture"),
        Case("png-bomb-header", {"model.xml": legged('<asset><texture name="t" type="2d" file="t.png"/></asset>'),
                                 "t.png": png(60000, 60000, pixels=False)}, "cap"),
        Case("user-data", {"model.xml": legged('<size nuserdata="100000000"/>')}, "nuserdata"),
        Case("timestep", {"model.xml": legged('<option timestep="1"/>')}, "timestep"),
        Case("too-many-bodies", {"model.xml": legged(world="".join('<body pos="0 0 5"><geom size=".01"/></body>' for _ in range(300)))}, "bodies"),
        Case("malformed", {"model.xml": b"<mujoco><worldbody></mujoco>"}, "well-formed"),
        Case("not-utf8", {"model.xml": "<mujoco model='é'/>".encode("latin-1")}, "UTF-8"),
        Case("wrong-root", {"model.xml": b"<robot name='urdf'/>"}, "root element"),
        Case("no-legs", {"model.xml": b'<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>'}, "legs"),
        Case("zip-slip", {}, "'..' is refused", archive=zip_of([("model.xml", legged()), ("../../evil.txt", b"x")])),
        Case("zip-absolute", {}, "absolute", archive=zip_of([("model.xml", legged()), ("/tmp/evil.txt", b"x")])),
        Case("zip-symlink", {}, "link", archive=zip_of([("model.xml", legged())], link="meshes/passwd.stl")),
        Case("zip-bomb", {}, "zip bomb", archive=zip_of([("model.xml", legged()), ("big.bin", b"\0" * (8 * 1024 * 1024))])),
        Case("zip-malformed", {}, "zip", archive=b"PK\x03\x04 this is not a zip"),
    ]
    return out


def fill(files: dict[str, bytes], secret: Path, missing: Path) -> dict[str, bytes]:
    return {k: v.replace(b"{SECRET}", str(secret).encode()).replace(b"{MISSING}", str(missing).encode())
            for k, v in files.items()}

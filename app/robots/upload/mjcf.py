"""Pre-parse of an uploaded MJCF: the model MuJoCo is given is one this module wrote.

The XML parser refuses DTDs, entities and external references (defusedxml) and stops at
the byte, depth and element caps while it reads. Refused outright: `model`, `attach`,
`extension`, `plugin`, `instance` (and a `plugin` attribute), deformables (`composite`,
`flexcomp`, `flex`), every attribute ending in `dir` (meshdir, texturedir, assetdir; not a light's `dir`) and
`strippath="true"`. `<include file>` and every `file*` attribute are resolved only to
files of the upload, by their normalised name relative to the model's folder; includes
are inlined here (depth capped), file attributes rewritten to that name. Attributes that
make MuJoCo allocate (size memory, replicate count, texture and height-field sizes, user
data sizes, sensor samples) are capped. The result is serialised anew: MuJoCo never sees
the uploaded text itself.
"""

from __future__ import annotations

import dataclasses
import posixpath
import re
import struct
import xml.etree.ElementTree as ET

import defusedxml
from defusedxml.ElementTree import DefusedXMLParser

from app.robots.upload.errors import RefusedUpload
from app.robots.upload.files import Upload, normalise
from app.robots.upload.limits import LIMITS, Limits

REFUSED = {
    "model": "a sub-model (<model>) is refused: upload one model",
    "attach": "<attach> is refused: upload one model",
    "extension": "plugins (<extension>) are refused",
    "plugin": "plugins (<plugin>) are refused",
    "instance": "plugin instances (<instance>) are refused",
    "composite": "deformable bodies (<composite>) are not supported for uploaded robots",
    "flexcomp": "deformable bodies (<flexcomp>) are not supported for uploaded robots",
    "flex": "deformable bodies (<flex>) are not supported for uploaded robots",
}
FILE_ATTRS = ("file", "fileback", "filedown", "filefront", "fileleft", "fileright", "fileup")
_INT_CAPS = {  # attribute -> Limits field (any element)
    "nuserdata": "max_user_size", "nuser_body": "max_user_size", "nuser_jnt": "max_user_size",
    "nuser_geom": "max_user_size", "nuser_site": "max_user_size", "nuser_cam": "max_user_size",
    "nuser_tendon": "max_user_size", "nuser_actuator": "max_user_size", "nuser_sensor": "max_user_size",
    "nkey": "max_keys", "njmax": "max_user_size", "nconmax": "max_user_size",
    "offwidth": "max_render_size", "offheight": "max_render_size", "shadowsize": "max_render_size",
}
_SMALL_CAPS = {"nsample": 1000, "actdim": 100, "dim": 1000, "offsamples": 64, "numslices": 1000,
               "numstacks": 1000, "numquads": 1000}
_MEMORY = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([KMGTP]?)\s*$", re.IGNORECASE)


@dataclasses.dataclass
class Sanitised:
    xml: str  # the model MuJoCo compiles and the store keeps
    assets: dict[str, bytes]  # the files it references, by the name it references them with


class _Counting(ET.TreeBuilder):
    """Builds the tree and stops at the depth and element caps while the parser reads."""

    def __init__(self, limits: Limits, budget: list[int], what: str):
        super().__init__()
        self.limits, self.budget, self.what, self.depth = limits, budget, what, 0

    def start(self, tag, attrs):
        self.depth += 1
        self.budget[0] += 1
        if self.depth > self.limits.max_depth:
            raise RefusedUpload(f"{self.what}: elements nested deeper than {self.limits.max_depth}")
        if self.budget[0] > self.limits.max_elements:
            raise RefusedUpload(f"more than {self.limits.max_elements} XML elements")
        return super().start(tag, attrs)

    def end(self, tag):
        self.depth -= 1
        return super().end(tag)


def parse_xml(data: bytes, what: str, limits: Limits = LIMITS, budget: list[int] | None = None) -> ET.Element:
    if len(data) > limits.max_xml_bytes:
        raise RefusedUpload(f"{what} is larger than {limits.max_xml_bytes} bytes", status=413)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise RefusedUpload(f"{what} is not UTF-8 text") from None
    parser = DefusedXMLParser(target=_Counting(limits, budget if budget is not None else [0], what),
                              forbid_dtd=True, forbid_entities=True, forbid_external=True)
    try:
        parser.feed(text)
        root = parser.close()
    except defusedxml.DTDForbidden:
        raise RefusedUpload(f"{what}: a DTD (<!DOCTYPE>) is refused") from None
    except defusedxml.EntitiesForbidden:
        raise RefusedUpload(f"{what}: XML entities (<!ENTITY>) are refused") from None
    except defusedxml.ExternalReferenceForbidden:
        raise RefusedUpload(f"{what}: external XML references are refused") from None
    except ET.ParseError as e:
        raise RefusedUpload(f"{what} is not well-formed XML: {e}") from None
    if root.tag != "mujoco":
        raise RefusedUpload(f"{what}: the root element must be <mujoco>, not <{str(root.tag)[:40]}>")
    return root


class _Sanitiser:
    def __init__(self, upload: Upload, limits: Limits):
        self.upload, self.limits = upload, limits
        self.base = posixpath.dirname(upload.model)
        self.assets: dict[str, bytes] = {}
        self.budget = [0]

    def resolve(self, ref: str, what: str) -> tuple[str, bytes]:
        """The uploaded file a reference names: (its name relative to the model, bytes)."""
        name = normalise(ref, what, self.limits)
        key = posixpath.join(self.base, name) if self.base else name
        if key not in self.upload.files:
            # The same words whatever the host holds: the name is only looked up in the upload.
            raise RefusedUpload(f"{what} {ref[:120]!r} is not one of the uploaded files", field="file")
        return name, self.upload.files[key]

    def walk(self, elem: ET.Element, include_depth: int, replicas: int) -> None:
        i = 0
        while i < len(elem):
            child = elem[i]
            if child.tag == "include":
                inlined = self.include(child, include_depth)
                elem[i:i + 1] = inlined
                continue  # the inlined elements are checked in turn, from position i
            self.check(child, replicas)
            count = _replicate_count(child, self.limits) if child.tag == "replicate" else 1
            if replicas * count > self.limits.max_replicate:
                raise RefusedUpload(f"<replicate> counts multiply to more than {self.limits.max_replicate}")
            self.walk(child, include_depth, replicas * count)
            i += 1

    def include(self, elem: ET.Element, depth: int) -> list[ET.Element]:
        extra = set(elem.attrib) - {"file"}
        if extra or "file" not in elem.attrib:
            raise RefusedUpload("<include> takes one attribute, file")
        if depth >= self.limits.max_include_depth:
            raise RefusedUpload(f"<include> nested deeper than {self.limits.max_include_depth}")
        name, data = self.resolve(elem.attrib["file"], "<include file>")
        root = parse_xml(data, f"included file {name!r}", self.limits, self.budget)
        holder = ET.Element("holder")
        holder.extend(list(root))
        self.walk(holder, depth + 1, 1)
        return list(holder)

    def check(self, elem: ET.Element, replicas: int) -> None:
        tag = elem.tag
        if not isinstance(tag, str) or "{" in tag:
            raise RefusedUpload("XML namespaces are refused in MJCF")
        if tag in REFUSED:
            raise RefusedUpload(REFUSED[tag], field="model")
        for attr, value in list(elem.attrib.items()):
            self.check_attr(elem, attr, value)

    def check_attr(self, elem: ET.Element, attr: str, value: str) -> None:
        tag, lim = elem.tag, self.limits
        if attr.endswith("dir") and attr != "dir":  # meshdir, texturedir, assetdir (a light's dir is a direction)
            raise RefusedUpload(f"<{tag} {attr}> is refused: files are named by their path inside the upload")
        if attr in ("plugin", "instance"):
            raise RefusedUpload(f"<{tag} {attr}>: plugins are refused")
        if attr == "strippath" and value.strip().lower() == "true":
            raise RefusedUpload("<compiler strippath=\"true\"> is refused: files are named by their path inside the upload")
        if attr in FILE_ATTRS:
            name, data = self.resolve(value, f"<{tag} {attr}>")
            if tag in ("texture", "hfield"):
                _check_image(data, name, tag, lim)
            self.assets[name] = data
            elem.set(attr, name)
        elif attr in _INT_CAPS:
            _cap(tag, attr, value, getattr(lim, _INT_CAPS[attr]))
        elif attr in _SMALL_CAPS:
            _cap(tag, attr, value, _SMALL_CAPS[attr])
        elif tag == "size" and attr == "memory":
            _check_memory(value, lim)
        if tag == "texture" and attr in ("width", "height"):
            w, h = (_number(tag, a, elem.get(a, "0")) for a in ("width", "height"))
            if w * h > lim.max_texture_pixels:
                raise RefusedUpload(f"<texture> of {int(w)}x{int(h)} pixels; the cap is {lim.max_texture_pixels}")
        if tag == "hfield" and attr in ("nrow", "ncol"):
            n = _number(tag, "nrow", elem.get("nrow", "0")) * _number(tag, "ncol", elem.get("ncol", "0"))
            if n > lim.max_hfield_samples:
                raise RefusedUpload(f"<hfield> of {int(n)} samples; the cap is {lim.max_hfield_samples}")
        if tag == "numeric" and attr == "size":
            _cap(tag, attr, value, lim.max_numeric_size)


def _number(tag: str, attr: str, value: str) -> float:
    try:
        v = float(value.split()[0]) if value.split() else 0.0
    except ValueError:
        raise RefusedUpload(f"<{tag} {attr}> is not a number: {value[:40]!r}") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise RefusedUpload(f"<{tag} {attr}> is not a finite number")
    return v


def _cap(tag: str, attr: str, value: str, cap: int) -> None:
    for part in value.split() or ["0"]:
        if _number(tag, attr, part) > cap:
            raise RefusedUpload(f"<{tag} {attr}={value[:40]!r}> is over the cap of {cap}")


def _replicate_count(elem: ET.Element, limits: Limits) -> int:
    v = _number("replicate", "count", elem.get("count", "1"))
    if v < 1 or v > limits.max_replicate:
        raise RefusedUpload(f"<replicate count={elem.get('count')!r}>: the cap is {limits.max_replicate}")
    return int(v)


def _check_memory(value: str, limits: Limits) -> None:
    if value.strip() == "-1":
        return
    m = _MEMORY.match(value)
    if not m:
        raise RefusedUpload(f"<size memory={value[:40]!r}> is not a size")
    scale = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40, "P": 1 << 50}[m.group(2).upper()]
    if float(m.group(1)) * scale > limits.max_arena_bytes:
        raise RefusedUpload(f"<size memory={value[:40]!r}> is over the cap of {limits.max_arena_bytes} bytes")


def _check_image(data: bytes, name: str, tag: str, limits: Limits) -> None:
    """A PNG's header, or MuJoCo's custom binary header (two int32), before anything decodes it."""
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        if len(data) < 24:
            raise RefusedUpload(f"<{tag} file> {name!r}: a truncated PNG")
        w, h = struct.unpack(">II", data[16:24])
    elif len(data) >= 8:
        w, h = struct.unpack("<ii", data[:8])
    else:
        raise RefusedUpload(f"<{tag} file> {name!r}: neither a PNG nor a MuJoCo binary {tag}")
    cap = limits.max_texture_pixels if tag == "texture" else limits.max_hfield_samples
    if w < 0 or h < 0 or w * h > cap:
        raise RefusedUpload(f"<{tag} file> {name!r} is {w}x{h}; the cap is {cap} pixels")


def sanitise_mjcf(upload: Upload, limits: Limits = LIMITS) -> Sanitised:
    """The model as this module rewrites it, with the assets it uses; RefusedUpload otherwise."""
    s = _Sanitiser(upload, limits)
    root = parse_xml(upload.files[upload.model], f"model {upload.model!r}", limits, s.budget)
    s.check(root, 1)
    s.walk(root, 0, 1)
    if s.budget[0] > limits.max_elements:
        raise RefusedUpload(f"more than {limits.max_elements} XML elements")
    return Sanitised(xml=ET.tostring(root, encoding="unicode"), assets=s.assets)

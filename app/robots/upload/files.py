"""The files of an upload, by normalised relative name: from request parts, from a folder
(the CLI) or from one zip (zip-slip, links, encryption and zip bombs refused). Nothing here
opens a host path that the upload names: a name is only ever a key into the upload."""

from __future__ import annotations

import dataclasses
import io
import re
import stat
import zipfile
from pathlib import Path

from app.robots.upload.errors import RefusedUpload
from app.robots.upload.limits import LIMITS, Limits

_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.\-]*:")


def normalise(name: str, what: str, limits: Limits = LIMITS) -> str:
    """A relative name inside the upload ('a/b.stl'), or RefusedUpload naming `what`:
    absolute paths, drive letters and URI schemes, '..', backslashes, control characters."""
    shown = name[:120]
    if not name or len(name) > limits.max_name_length:
        raise RefusedUpload(f"{what}: a file name must have 1 to {limits.max_name_length} characters", field="file")
    if any(ord(c) < 32 or c == "\x7f" for c in name) or "\\" in name:
        raise RefusedUpload(f"{what} {shown!r}: control characters and backslashes are refused in file names",
                            field="file")
    if name.startswith(("/", "~")) or _SCHEME.match(name):
        raise RefusedUpload(f"{what} {shown!r}: absolute paths, '~' and URI schemes are refused; "
                            "name a file of the upload by its relative name", field="file")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if ".." in parts:
        raise RefusedUpload(f"{what} {shown!r}: '..' is refused in file names", field="file")
    if not parts:
        raise RefusedUpload(f"{what} {shown!r}: not a file name", field="file")
    return "/".join(parts)


@dataclasses.dataclass
class Upload:
    """The model's name and every uploaded file (the model included) by normalised name."""

    model: str
    files: dict[str, bytes]

    def __post_init__(self):
        if self.model not in self.files:
            raise RefusedUpload(f"the model {self.model!r} is not among the uploaded files")


class _Collector:
    def __init__(self, limits: Limits):
        self.limits, self.files, self.total = limits, {}, 0

    def add(self, name: str, data: bytes, what: str = "file") -> str:
        key = normalise(name, what, self.limits)
        lim = self.limits
        if key in self.files:
            raise RefusedUpload(f"{what} {key!r} is uploaded twice", field="file")
        if len(self.files) >= lim.max_files:
            raise RefusedUpload(f"more than {lim.max_files} files in the upload", field="file", status=413)
        if len(data) > lim.max_file_bytes:
            raise RefusedUpload(f"{what} {key!r} is larger than {lim.max_file_bytes} bytes", field="file", status=413)
        self.total += len(data)
        if self.total > lim.max_upload_bytes:
            raise RefusedUpload(f"the upload is larger than {lim.max_upload_bytes} bytes", field="file", status=413)
        self.files[key] = data
        return key


def from_parts(model_name: str, model: bytes, assets: list[tuple[str, bytes]], limits: Limits = LIMITS) -> Upload:
    """The model file and asset files as a request carried them (each asset's name is its
    relative path, e.g. 'meshes/foot.stl')."""
    c = _Collector(limits)
    key = c.add(model_name or "model.xml", model, "model")
    for name, data in assets:
        c.add(name, data, "asset")
    return Upload(key, c.files)


def from_dir(model_path: Path, assets_dir: Path | None, limits: Limits = LIMITS) -> Upload:
    """The CLI's upload: the model file and every regular file under assets_dir (links are
    not followed), named relative to assets_dir. The user chose these paths; the model's
    own references are still only looked up among them."""
    c = _Collector(limits)
    key = c.add(model_path.name, _read_capped(model_path, limits), "model")
    if assets_dir is not None:
        root = assets_dir.resolve()
        for p in sorted(root.rglob("*")):
            if p.is_symlink() or not p.is_file():
                continue
            rel = p.relative_to(root).as_posix()
            if rel == key and p.resolve() == model_path.resolve():
                continue
            c.add(rel, _read_capped(p, limits), "asset")
    return Upload(key, c.files)


def _read_capped(path: Path, limits: Limits) -> bytes:
    with open(path, "rb") as f:
        data = f.read(limits.max_file_bytes + 1)
    if len(data) > limits.max_file_bytes:
        raise RefusedUpload(f"{path.name!r} is larger than {limits.max_file_bytes} bytes", field="file", status=413)
    return data


def from_zip(data: bytes, model_name: str | None = None, limits: Limits = LIMITS) -> Upload:
    """One zip holding the model and its assets. The model is `model_name` (its path in the
    zip) or else the one .xml file at the zip's top level (or under its one top folder)."""
    if len(data) > limits.max_upload_bytes:
        raise RefusedUpload(f"the zip is larger than {limits.max_upload_bytes} bytes", field="archive", status=413)
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
        infos = zf.infolist()
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as e:
        raise RefusedUpload(f"not a readable zip: {type(e).__name__}", field="archive") from None
    if len(infos) > limits.max_files * 2:
        raise RefusedUpload(f"more than {limits.max_files} files in the zip", field="archive", status=413)
    c = _Collector(limits)
    with zf:
        for info in infos:
            if info.is_dir():
                normalise(info.filename.rstrip("/") or ".", "zip entry", limits)
                continue
            _check_entry(info, limits)
            c.add(info.filename, _read_entry(zf, info, limits), "zip entry")
    files = c.files
    prefix = _one_top_folder(files)
    if prefix:
        files = {k[len(prefix):]: v for k, v in files.items()}
    if model_name:
        key = normalise(model_name, "model", limits)
        key = key[len(prefix):] if prefix and key.startswith(prefix) else key
    else:
        top = sorted(k for k in files if "/" not in k and k.lower().endswith(".xml"))
        if len(top) != 1:
            raise RefusedUpload(f"the zip has {len(top)} .xml files at its top; name the model (model_path)",
                                field="model_path")
        key = top[0]
    return Upload(key, files)


def _check_entry(info: zipfile.ZipInfo, limits: Limits) -> None:
    name = info.filename
    normalise(name, "zip entry", limits)  # zip-slip: absolute names, '..', drive letters, backslashes
    mode = info.external_attr >> 16
    if stat.S_ISLNK(mode):
        raise RefusedUpload(f"zip entry {name[:120]!r} is a symbolic link; links are refused", field="archive")
    if info.flag_bits & 0x1:
        raise RefusedUpload(f"zip entry {name[:120]!r} is encrypted", field="archive")
    if info.file_size > limits.max_file_bytes:
        raise RefusedUpload(f"zip entry {name[:120]!r} is larger than {limits.max_file_bytes} bytes",
                            field="archive", status=413)
    if info.file_size > 1024 * 1024 and info.file_size > limits.max_zip_ratio * max(info.compress_size, 1):
        raise RefusedUpload(f"zip entry {name[:120]!r} expands more than {limits.max_zip_ratio}x (a zip bomb?)",
                            field="archive", status=413)


def _read_entry(zf: zipfile.ZipFile, info: zipfile.ZipInfo, limits: Limits) -> bytes:
    """At most the declared size (a header that lies about it is caught here)."""
    try:
        with zf.open(info) as f:
            data = f.read(info.file_size + 1)
    except (zipfile.BadZipFile, NotImplementedError, RuntimeError, ValueError, OSError, EOFError) as e:
        raise RefusedUpload(f"zip entry {info.filename[:120]!r} cannot be read: {type(e).__name__}",
                            field="archive") from None
    if len(data) > info.file_size:
        raise RefusedUpload(f"zip entry {info.filename[:120]!r} is larger than its header says", field="archive")
    return data


def _one_top_folder(files: dict[str, bytes]) -> str:
    tops = {k.split("/", 1)[0] for k in files}
    if len(tops) == 1 and all("/" in k for k in files):
        return tops.pop() + "/"
    return ""

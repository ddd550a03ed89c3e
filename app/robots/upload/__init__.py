"""Uploaded robots: a hostile MJCF made safe to store and simulate (docs/robots.md).

``prepare(upload)`` runs the whole defence: the pre-parse and rewrite (mjcf.py), the
confined compile with the size caps and the leg map found or checked (sandbox.py,
child.py, compiled.py). What it returns is what the store keeps: the rewritten model, the
assets it references, the leg map, the sizes and the content hash; never the raw upload.
"""

from __future__ import annotations

import dataclasses


from app.robots.legmap import LegMap, LegMapError, content_hash
from app.robots.upload.errors import RefusedUpload
from app.robots.upload.files import Upload, from_dir, from_parts, from_zip, normalise
from app.robots.upload.limits import LIMITS, Limits
from app.robots.upload.mjcf import sanitise_mjcf

__all__ = ["LIMITS", "Limits", "Prepared", "RefusedUpload", "Upload", "from_dir", "from_parts", "from_zip",
           "normalise", "prepare", "parse_legs"]


@dataclasses.dataclass(frozen=True)
class Prepared:
    name: str
    xml: str
    assets: dict[str, bytes]
    legs: LegMap
    detected: bool  # the leg map was found from the kinematic tree (show it to the user to confirm)
    points: dict  # each leg's hip and foot in the trunk frame, for the top view
    stats: dict
    sandbox: dict
    content_hash: str


def parse_legs(data: str | bytes | dict | None) -> dict | None:
    """A leg map given by the user (JSON), checked for form here and against the model in
    the sandbox; RefusedUpload (field legs) when malformed."""
    if data is None or data == "" or data == b"":
        return None
    if isinstance(data, (bytes, str)) and len(data) > 256 * 1024:
        raise RefusedUpload("the leg map is larger than 256 KiB", field="legs", status=413)
    try:
        return LegMap.parse(data).to_json()
    except LegMapError as e:
        raise RefusedUpload(f"legs: {e}", field="legs") from None


def prepare(upload: Upload, legs: str | bytes | dict | None = None, forward: str | None = None,
            name: str | None = None, limits: Limits = LIMITS) -> Prepared:
    from app.robots.upload.sandbox import compile_confined

    if forward is not None and forward not in ("+x", "-x", "+y", "-y"):
        raise RefusedUpload(f"forward must be +x, -x, +y or -y, got {str(forward)[:20]!r}", field="forward")
    given = parse_legs(legs)
    clean = sanitise_mjcf(upload, limits)
    answer = compile_confined(clean, given, forward, limits)
    leg_map = LegMap.parse(answer["legs"])
    label = (name or upload.model.rsplit("/", 1)[-1].removesuffix(".xml"))[:200]
    if not label.strip() or any(ord(c) < 32 for c in label):
        raise RefusedUpload("name must be printable text", field="name")
    return Prepared(name=label, xml=clean.xml, assets=dict(clean.assets), legs=leg_map, detected=answer["detected"],
                    points=answer["points"], stats=answer["stats"], sandbox=answer["sandbox"],
                    content_hash=content_hash(clean.xml, clean.assets, leg_map))



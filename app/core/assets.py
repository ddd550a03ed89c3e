"""Where the files beside the code live: the dashboard (web/) and the migrations
(migrations/). In a checkout (or an editable install) they sit next to the app package;
a wheel carries them inside it, as app/_assets/<name> (setup.py copies them at build)."""

from __future__ import annotations

from pathlib import Path

_APP = Path(__file__).resolve().parents[1]  # the app package


def asset_dir(name: str) -> Path:
    packaged = _APP / "_assets" / name
    return packaged if packaged.is_dir() else _APP.parent / name

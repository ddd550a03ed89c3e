"""Which source made this run: the git commit of the checkout (or of the wheel's build,
recorded in app/_build_info.json by setup.py), so a bundle can say how to install exactly
the version that made it."""

from __future__ import annotations

import functools
import json
import subprocess
from pathlib import Path

_APP = Path(__file__).resolve().parents[1]  # the app package


@functools.lru_cache(maxsize=1)
def source_commit() -> str | None:
    """The commit hash, with "+dirty" when the checkout had uncommitted changes; None if unknown."""
    info = _APP / "_build_info.json"
    if info.is_file():
        return json.loads(info.read_text()).get("commit")
    return git_commit(_APP.parent)


def git_commit(root: Path) -> str | None:
    if not (root / ".git").exists():
        return None
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return sha + ("+dirty" if dirty else "")

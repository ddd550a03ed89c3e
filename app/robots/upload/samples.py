"""Third-party legged robots prepared as a user's upload is (app/robots/upload ``prepare``),
for reproductions that need an uploaded robot without a server: the dm_control quadruped and
the Gymnasium ant, read from their installed wheels (the test extra installs both; nothing is
downloaded)."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

SAMPLES = ("dm_quadruped", "gym_ant")


def _package_file(package: str, rel: str) -> Path:
    import importlib.util

    spec = importlib.util.find_spec(package)  # the installed wheel, not imported
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError(f"{package} is not installed (the test extra brings it: pip install -e '.[test]')")
    path = Path(list(spec.submodule_search_locations)[0]) / rel
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing from the installed {package}")
    return path


def sample_robot(name: str):
    """(robot id, the stored robot) of one of ``SAMPLES``, prepared as the API and the CLI
    store an upload (the id: the first 32 hex digits of its content hash)."""
    from app.robots.legmap import Robot
    from app.robots.upload import from_dir, prepare

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if name == "dm_quadruped":
            path = _package_file("dm_control", "suite/quadruped.xml")
            shutil.copytree(path.parent / "common", folder / "common")  # its three included files
        elif name == "gym_ant":
            path = _package_file("gymnasium", "envs/mujoco/assets/ant.xml")
        else:
            raise ValueError(f"unknown sample robot {name!r}: {sorted(SAMPLES)}")
        p = prepare(from_dir(path, folder))
    return p.content_hash[:32], Robot(name, p.xml, p.assets, p.legs)

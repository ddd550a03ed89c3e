"""Metadata lives in pyproject.toml. This file only makes the wheel carry what the code
needs beside the app package - web/ (dashboard) and migrations/ (Alembic) - as
app/_assets/ (found by app/core/assets.py); a plain `pip install .` then runs `gaitmend serve`."""

import json
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ASSETS = ("web", "migrations")


class BuildWithAssets(build_py):
    def run(self):
        super().run()
        root = Path(__file__).resolve().parent
        for name in ASSETS:
            dest = Path(self.build_lib) / "app" / "_assets" / name
            shutil.rmtree(dest, ignore_errors=True)
            shutil.copytree(root / name, dest, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        # The commit this wheel was built from, so its bundles can say how to install it again.
        try:
            commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                                    timeout=10, check=True).stdout.strip() or None
        except (OSError, subprocess.SubprocessError):
            commit = None
        (Path(self.build_lib) / "app" / "_build_info.json").write_text(json.dumps({"commit": commit}))


setup(cmdclass={"build_py": BuildWithAssets})

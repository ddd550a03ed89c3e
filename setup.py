"""Metadata lives in pyproject.toml. This file only makes the wheel carry what the code
needs beside the app package - web/ (dashboard) and migrations/ (Alembic) - as
app/_assets/ (found by app/assets.py); a plain `pip install .` then runs `gaitmend serve`."""

import shutil
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


setup(cmdclass={"build_py": BuildWithAssets})

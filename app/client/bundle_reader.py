"""``open_bundle``: a result bundle (zip or unpacked folder) as Python objects: the
manifest and summary as dicts, history.csv and each trace as pandas DataFrames, the
trajectories as NumPy arrays, the damaged robot as a ``mujoco.MjModel``, the kind's
figures (shown inline in a notebook), and ``verify()`` as `gaitmend verify` does it."""

from __future__ import annotations

import dataclasses
import functools
import io
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np


@dataclasses.dataclass(frozen=True)
class Figure:
    """One of the kind's plots: ``svg`` and ``png`` bytes (either may be None), what it
    shows; a notebook displays it inline."""

    name: str
    description: str
    svg: bytes | None
    png: bytes | None

    def _repr_png_(self) -> bytes | None:
        return self.png

    def _repr_svg_(self) -> str | None:
        return self.svg.decode() if self.svg is not None and self.png is None else None

    def save(self, path: str | Path) -> Path:
        """Write it as ``path`` (.svg or .png, as the suffix says)."""
        path = Path(path)
        data = self.svg if path.suffix == ".svg" else self.png
        if data is None:
            raise ValueError(f"figure {self.name!r} has no {path.suffix or 'such'} version")
        path.write_bytes(data)
        return path


@dataclasses.dataclass(frozen=True)
class Verification:
    """What ``Bundle.verify`` found: ``outcome`` (identical, within_tolerance or different:
    app/results/verify.py), the first ``difference`` (None when identical) and the whole
    ``comparison``. True unless different, as `gaitmend verify` exits 0; ``same``: bit for bit."""

    outcome: str
    difference: str | None
    comparison: Any

    @property
    def same(self) -> bool:
        return self.outcome == "identical"

    def __bool__(self) -> bool:
        return self.outcome != "different"


class Bundle:
    """A result bundle. Members are read on first use; nothing is unpacked to disk."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.is_dir():
            self._names = sorted(p.relative_to(self.path).as_posix() for p in self.path.rglob("*") if p.is_file())
        else:
            try:
                with zipfile.ZipFile(self.path) as z:
                    self._names = [n for n in z.namelist() if not n.endswith("/")]
            except (zipfile.BadZipFile, FileNotFoundError, IsADirectoryError) as e:
                raise ValueError(f"{self.path} is not a bundle zip or folder: {e}") from None
        if "manifest.json" not in self._names:
            raise ValueError(f"{self.path} is not a gaitmend bundle (no manifest.json)")

    def __repr__(self) -> str:
        return f"<gaitmend.Bundle {self.job_id} {self.kind} ({self.path.name})>"

    @property
    def files(self) -> list[str]:
        return list(self._names)

    def read(self, name: str) -> bytes:
        """One member's bytes, by its name in the bundle (e.g. "plots/com.svg")."""
        if name not in self._names:
            raise KeyError(f"no {name!r} in the bundle; it has {', '.join(self._names)}")
        if self.path.is_dir():
            return (self.path / name).read_bytes()
        with zipfile.ZipFile(self.path) as z:
            return z.read(name)

    # -- what the job was and what it found ----------------------------------------------------
    @functools.cached_property
    def manifest(self) -> dict[str, Any]:
        return json.loads(self.read("manifest.json"))

    @functools.cached_property
    def summary(self) -> dict[str, Any]:
        """result.json: the kind's summary of the run."""
        return json.loads(self.read("result.json"))

    @property
    def spec(self) -> dict[str, Any]:
        return self.manifest["spec"]

    @property
    def kind(self) -> str:
        return self.manifest["kind"]

    @property
    def job_id(self) -> str:
        return self.manifest["job_id"]

    @property
    def readme(self) -> str:
        return self.read("README.md").decode() if "README.md" in self._names else ""

    @property
    def headline(self):
        """The kind's headline numbers of this result (needs the kind installed here)."""
        import pandas as pd

        from app.jobs.registry import get_kind

        return pd.DataFrame(get_kind(self.kind).headline(self.summary),
                            columns=["label", "value", "unit", "better", "target", "met"])

    @functools.cached_property
    def history(self):
        """history.csv as a DataFrame (one row per generation, or per run for some kinds)."""
        import pandas as pd

        data = self.read("history.csv")
        return pd.read_csv(io.BytesIO(data)) if data.strip() else pd.DataFrame()

    @functools.cached_property
    def archive(self):
        """A repertoire bundle's map, one row per elite (app/client/repertoire.py)."""
        from app.client.repertoire import bundle_archive

        return bundle_archive(self)

    # -- trajectories and the robot -------------------------------------------------------------
    @property
    def trace_names(self) -> list[str]:
        return [n[len("trajectories/"):-4] for n in self._names if n.startswith("trajectories/") and n.endswith(".npz")]

    @functools.cached_property
    def trajectories(self) -> dict[str, dict[str, np.ndarray]]:
        """{trace: {array name: array}} from trajectories/<trace>.npz (per-step arrays
        share their first axis with ``time_s``)."""
        return {n: dict(np.load(io.BytesIO(self.read(f"trajectories/{n}.npz")))) for n in self.trace_names}

    def trace(self, name: str):
        """One trace as a DataFrame (trajectories/<name>.csv: a column per 1-D array or
        component, e.g. com_m_0, com_m_1, com_m_2), indexed by ``time_s``."""
        import pandas as pd

        df = pd.read_csv(io.BytesIO(self.read(f"trajectories/{name}.csv")))
        return df.set_index("time_s") if "time_s" in df.columns else df

    @property
    def robot_xml(self) -> str:
        return self.read("robot.xml").decode()

    @functools.cached_property
    def model(self):
        """The damaged robot exactly as simulated (robot.xml) as a ``mujoco.MjModel``."""
        import mujoco

        return mujoco.MjModel.from_xml_string(self.robot_xml)

    # -- figures, video, verification ---------------------------------------------------------------
    @functools.cached_property
    def figures(self) -> dict[str, Figure]:
        """{stem: Figure} of plots/ (the kind's figures, described as in the bundle README)."""
        from app.jobs.registry import KINDS

        kind = KINDS.get(self.kind)
        stems = dict.fromkeys(Path(n).stem for n in self._names if n.startswith("plots/"))
        out = {}
        for stem in stems:
            svg, png = f"plots/{stem}.svg", f"plots/{stem}.png"
            what = kind.describe_file(png if png in self._names else svg) if kind is not None else stem
            out[stem] = Figure(stem, what, self.read(svg) if svg in self._names else None,
                               self.read(png) if png in self._names else None)
        return out

    def video(self, out: str | Path = "walk.mp4", **kw) -> Path:
        """Render the recovered gait and its baseline side by side as an MP4 here
        (``gaitmend video``): width, height, fps, camera ("follow" or "fixed"), seconds."""
        from app.results.video import bundle_files, clip_of_files, write_mp4

        write_mp4(clip_of_files(bundle_files(self.path)), Path(out), **kw)
        return Path(out)

    def verify(self) -> Verification:
        """Re-run the job here from its manifest and compare every number of the fresh
        result with result.json, wall-clock figures excepted (`gaitmend verify`)."""
        from app.jobs.registry import parse_spec
        from app.results.verify import compare, rerun

        c = compare(self.summary, rerun(parse_spec(self.spec)))
        return Verification(c.outcome, c.first, c)


def open_bundle(path: str | Path) -> Bundle:
    """A result bundle, from its zip, its unpacked folder, or that folder's manifest.json."""
    path = Path(path)
    return Bundle(path.parent if path.name == "manifest.json" else path)

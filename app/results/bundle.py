"""Result bundles: one self-contained zip per job (format in DESIGN.md).

Written to a temporary file and renamed into place, so a reader never sees half a bundle.
"""

from __future__ import annotations

import csv
import datetime as dt
import functools
import hashlib
import io
import json
import math
import os
import platform
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from app import __version__
from app.core.host import machine
from app.jobs.base import JobResult, dumps
from app.jobs.registry import get_kind

BUNDLE_SCHEMA = 1


@functools.lru_cache(maxsize=1)
def versions() -> dict[str, str]:
    """Versions of what made the numbers, from the installed distributions' metadata
    (importing cma to read its __version__ imports scipy.stats: 1.7 s in every fresh worker
    process). Cached per process; a worker computes it before it forks its pool."""
    from importlib.metadata import version

    import mujoco

    from app.results.provenance import source_commit

    return {"gaitmend": __version__, "commit": source_commit(), "mujoco": mujoco.__version__, "numpy": np.__version__,
            "scipy": version("scipy"), "cma": version("cma"), "viser": version("viser"),
            "python": platform.python_version()}


def model_sha256(xml: str) -> str:
    return hashlib.sha256(xml.encode()).hexdigest()


def manifest(job_id: str, spec: Any, result: JobResult) -> dict:
    return {
        "bundle_schema": BUNDLE_SCHEMA,
        "job_id": job_id,
        "kind": spec.kind,
        "spec": spec.model_dump(mode="json"),
        "seed": spec.seed,
        "versions": dict(versions()),
        "machine": machine(),  # where the job ran (`gaitmend verify` prints it beside its own)
        "model_sha256": model_sha256(result.model_xml),
        "wall_s": result.summary["timing"]["wall_s"],
        "evaluations": result.evaluations,
        "sim_steps": result.sim_steps,
        "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
    }


def _finite(v):
    """JSON has no NaN or Infinity: a number a kind could not compute is written as null."""
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_finite(x) for x in v]
    return v


def _csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()


def trace_csv(tr: dict[str, np.ndarray]) -> str:
    """Flat per-step table of a trace: every array whose first axis is time ("time_s")
    becomes one column (1-D) or one column per component (2-D, suffix _0, _1, ...);
    booleans are written as 0/1. Arrays of other shapes stay in the .npz only."""
    t = np.asarray(tr["time_s"])
    header, cols = [], []
    for k, v in tr.items():
        v = np.asarray(v)
        if v.ndim == 0 or v.shape[0] != t.shape[0] or v.ndim > 2:
            continue
        if v.dtype == bool:
            v = v.astype(int)
        if v.ndim == 1:
            header.append(k)
            cols.append(v)
        else:
            header += [f"{k}_{i}" for i in range(v.shape[1])]
            cols += list(v.T)
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(zip(*[np.round(c, 6) if c.dtype.kind == "f" else c for c in cols]))
    return buf.getvalue()


README = """# gaitmend result bundle

Job `{job_id}` ({kind}: {title}, robot `{robot}`), made by gaitmend {version}.

## Verdict

{verdict}
| file | what it is |
|---|---|
{rows}
## Reproduce

{install}
```
gaitmend verify manifest.json       # re-runs the job and compares every number with result.json
gaitmend run manifest.json --out reproduced/
```

The same spec and seed give the same numbers (the search and the simulation are
deterministic; checked with MuJoCo {mujoco}).
"""


def verdict_text(kind, summary: dict) -> str:
    """The README's verdict: the job page's sentence (a fragile gait's first words say so)
    and the rule it is judged by, one paragraph each (app/jobs/verdict.py's verdict_lines)."""
    from app.jobs.verdict import verdict_lines

    return "".join(f"{line}\n\n" for line in verdict_lines(kind.verdict(summary)))


def install_text(commit: str | None) -> str:
    """How to install exactly the source that made the bundle (gaitmend is not on PyPI)."""
    if not commit:
        return (f"This bundle records no source commit: install gaitmend {__version__} from its source "
                "(`pip install .` in a checkout of that version).\n")
    sha = commit.removesuffix("+dirty")
    note = ("\nThe checkout had uncommitted changes when it ran, so that commit may differ from what ran.\n"
            if commit.endswith("+dirty") else "")
    return (f"Made from commit `{sha}`. Install exactly that source, in a fresh venv:\n\n"
            f"```\ngit clone <the gaitmend repository> gaitmend && cd gaitmend && git checkout {sha}\n"
            f"python3 -m venv .venv && . .venv/bin/activate && pip install .\n```\n{note}")


def write_bundle(path: Path, job_id: str, spec: Any, result: JobResult, extra_files: dict[str, bytes] | None = None) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    kind = get_kind(spec.kind)
    man = manifest(job_id, spec, result)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        plot_files = kind.figures(result, tmp / "plots")
        extra_files = dict(extra_files or {})
        replayable = {k: v for k, v in result.traces.items() if "qpos" in v}
        replay_rows: dict[str, str] = {}
        if replayable and "replay.viser" not in extra_files:
            import mujoco

            from app.results.replay import record_scenes, replay_tracks, scene_rows

            tracks = replay_tracks(kind, list(replayable))
            model = mujoco.MjModel.from_xml_string(result.model_xml)
            extra_files.update(record_scenes(model, replayable, tracks))  # one scene per track
            replay_rows = scene_rows(tracks)
        members: dict[str, bytes | str | Path] = {
            "manifest.json": json.dumps(man, indent=2), "result.json": json.dumps(_finite(json.loads(dumps(result.summary)))),
            "history.csv": _csv(result.history), "robot.xml": result.model_xml}
        for name, tr in result.traces.items():
            buf = io.BytesIO()
            np.savez_compressed(buf, **{k: np.asarray(v) for k, v in tr.items()})
            members[f"trajectories/{name}.npz"] = buf.getvalue()
            members[f"trajectories/{name}.csv"] = trace_csv(tr)
        for p in plot_files:
            members[f"plots/{p.name}"] = p
        members.update(kind.bundle_files(spec, result))
        members.update(extra_files)
        rows = kind.bundle_rows(list(members) + ["README.md"]) | replay_rows
        members["README.md"] = README.format(
            job_id=job_id, kind=spec.kind, title=kind.title, robot=getattr(spec, "robot", ""), version=__version__,
            mujoco=man["versions"]["mujoco"], install=install_text(man["versions"].get("commit")),
            verdict=verdict_text(kind, json.loads(members["result.json"])),
            rows="".join(f"| `{n}` | {d} |\n" for n, d in rows.items()))
        fd, tmp_zip = tempfile.mkstemp(dir=path.parent, suffix=".zip.part")
        os.close(fd)
        try:
            with zipfile.ZipFile(tmp_zip, "w", compression=zipfile.ZIP_DEFLATED) as z:
                for n, data in members.items():
                    if isinstance(data, Path):
                        z.write(data, n)
                    else:
                        z.writestr(n, data)
            os.replace(tmp_zip, path)
        except BaseException:
            Path(tmp_zip).unlink(missing_ok=True)
            raise
    return path


def read_spec_file(path: Path) -> dict:
    """A spec from a spec JSON, a bundle's manifest.json, or a bundle zip."""
    path = Path(path)
    if path.suffix == ".zip":
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("manifest.json"))
    else:
        data = json.loads(path.read_text())
    if isinstance(data, dict) and "bundle_schema" in data:
        return data["spec"]
    return data

"""Resumable reproductions (issue 28): an experiment's committed JSON under docs/ holds every
run it has finished, each appended (the file rewritten atomically) the moment the run
ends, so a reproduction killed midway keeps its finished runs and a re-run skips them.

A run is keyed by its spec (a JSON dict), its seed and the *code version of the science*:
a hash of the files whose code decides the run's numbers (a kind's science modules, its
robot, its optimiser; not its presentation). A run of other code is not reused: when code
of a new version writes its first run, the old runs move to ``superseded`` (kept in the
file as a record, never rendered), so a file's ``runs`` always come from one code version,
``code_version``; ``science_files`` holds each science file's own hash at that version, so
that ``staleness`` can name the files changed since (issue 45: a page says so at its top).
Work can be split over sessions (commit the file, continue later) and
machines (each writes its own copy; ``merge`` unites them by key).

File layout::

    {"schema": 1, "experiment": "tipping-cases", "command": "gaitmend reproduce ...",
     "params": {...}, "code_version": "3f2a...", "science": ["app/jobs/tipping/scenario.py", ...],
     "science_files": {"app/jobs/tipping/scenario.py": "9c1e...", ...},
     "planned": 12, "runs": [{"key", "name", "spec", "seed", "code_version", "wall_s", "cpu_s",
     "finished_at", "result"}], "superseded": [...]}
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from app.jobs.base import to_jsonable

SCHEMA = 1
ROOT = Path(__file__).resolve().parents[2]  # the repository (app/..)


# Science files moved without a byte changed, {the path ledgers recorded: where it is now}
# (issue 42: each built-in robot's module became its folder's __init__.py). A moved file is
# hashed under its recorded path and read where it is now, so a move alone changes no code
# version; a ledger that names the old path still finds the file.
MOVED: dict[str, str] = {
    f"app/robots/{r}.py": f"app/robots/{r}/__init__.py" for r in ("hexapod", "heavy_hexapod", "quadruped", "modular",
                                                                  "silo6")}
_RECORDED = {now: then for then, now in MOVED.items()}


def recorded_name(rel: str) -> str:
    """The path a science file is hashed under: the one ledgers recorded before it moved."""
    return _RECORDED.get(rel, rel)


def science_files(paths: Iterable[str], root: Path = ROOT) -> list[str]:
    """The files (relative to ``root``, sorted by the path they are hashed under) that
    ``paths`` name: a file as is (a moved one where it is now, ``MOVED``), a folder as every
    ``*.py`` under it."""
    out: set[str] = set()
    for p in paths:
        p = MOVED.get(p, p)
        full = root / p
        if full.is_dir():
            out.update(str(f.relative_to(root)) for f in full.rglob("*.py"))
        elif full.is_file():
            out.add(str(Path(p)))
        else:
            raise FileNotFoundError(f"science file {p!r} does not exist under {root}")
    return sorted(out, key=recorded_name)


def code_version(paths: Iterable[str], root: Path = ROOT) -> str:
    """12 hex digits of the sha256 over the science files' names and bytes: any change to
    the code that decides a run's numbers gives another version."""
    h = hashlib.sha256()
    for rel in science_files(paths, root):
        h.update(recorded_name(rel).encode() + b"\0" + (root / rel).read_bytes() + b"\0")
    return h.hexdigest()[:12]


def file_hashes(paths: Iterable[str], root: Path = ROOT) -> dict[str, str]:
    """{science file: 12 hex digits of the sha256 of its bytes}, for the files ``paths`` name."""
    return {recorded_name(rel): hashlib.sha256((root / rel).read_bytes()).hexdigest()[:12]
            for rel in science_files(paths, root)}


def _existing_files(paths: Iterable[str], root: Path) -> tuple[list[str], list[str]]:
    """(the science files ``paths`` name that exist now, the paths that name nothing)."""
    files, gone = set(), []
    for p in paths:
        try:
            files.update(science_files([p], root))
        except FileNotFoundError:
            gone.append(p)
    return sorted(files), gone


def staleness(data: dict[str, Any], root: Path = ROOT) -> dict[str, Any] | None:
    """None when a ledger's ``code_version`` is that of its science files as they are now;
    else {"recorded", "now", "changed": [files whose bytes differ, "path (new)" / "path
    (removed)"] or None when the file does not record its files' hashes}."""
    recorded, science = data.get("code_version"), data.get("science")
    if not recorded or not science:
        return None
    files, gone = _existing_files(science, root)
    now = code_version(files, root)
    if now == recorded and not gone:
        return None
    then = data.get("science_files")
    changed = None
    if isinstance(then, dict):
        cur = file_hashes(files, root) if files else {}
        changed = [f"{f} (removed)" if f not in cur else f"{MOVED.get(f, f)} (new)" if f not in then else MOVED.get(f, f)
                   for f in sorted(set(then) | set(cur)) if then.get(f) != cur.get(f)]  # a moved file where it is now
    return {"recorded": recorded, "now": now, "changed": changed}


def run_key(spec: dict[str, Any], seed: int, version: str) -> str:
    """The key of one run: spec + seed + code version (16 hex digits)."""
    text = json.dumps({"spec": to_jsonable(spec), "seed": int(seed), "code": version}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def finite(x: Any) -> Any:
    """``x`` (JSON-able) with NaN and infinities as None: JSON has neither, and a stored run
    must read back as it was returned."""
    if isinstance(x, float):
        return x if x == x and abs(x) != float("inf") else None
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [finite(v) for v in x]
    return x


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def write_json_atomic(path: Path, data: Any) -> None:
    """Write ``data`` to ``path`` so that a reader (or a kill) never sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(finite(to_jsonable(data)), fh, indent=1, allow_nan=False)
            fh.write("\n")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide a committed file from others
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class Ledger:
    """The runs of one experiment, in the JSON file ``path`` (None: kept in memory only).

    ``run(name, spec, seed, fn)`` returns the stored result of that run when the file holds
    it at this code version, else calls ``fn()`` (which returns the run's JSON-able result),
    appends the run and rewrites the file before returning."""

    def __init__(self, path: Path | None, experiment: str, command: str, params: dict[str, Any],
                 science: Sequence[str], planned: int | None = None, root: Path = ROOT):
        self.path = None if path is None else Path(path)
        self.version = code_version(science, root)
        self.science = list(science)
        self.hashes = file_hashes(science, root)
        self.data: dict[str, Any] = {"schema": SCHEMA, "experiment": experiment, "command": command,
                                     "params": to_jsonable(params), "code_version": self.version,
                                     "science": self.science, "science_files": self.hashes, "planned": planned,
                                     "runs": [], "superseded": []}
        if self.path is not None and self.path.exists():
            old = json.loads(self.path.read_text())
            if old.get("schema") != SCHEMA:
                raise ValueError(f"{self.path}: not a reproduction ledger (schema {old.get('schema')!r})")
            self.data["runs"], self.data["superseded"] = old.get("runs", []), old.get("superseded", [])
            self.data["code_version"] = old.get("code_version", self.version)
            if self.data["code_version"] != self.version:  # the file's runs are of its own science
                self.data["science"] = old.get("science", self.science)
                self.data["science_files"] = old.get("science_files")
        self.computed = 0  # runs this process computed (the rest came from the file)

    @property
    def runs(self) -> list[dict[str, Any]]:
        return self.data["runs"]

    def find(self, spec: dict[str, Any], seed: int) -> dict[str, Any] | None:
        key = run_key(spec, seed, self.version)
        return next((r for r in self.runs if r["key"] == key), None)

    def run(self, name: str, spec: dict[str, Any], seed: int, fn: Callable[[], Any],
            log: Callable[[str], None] = lambda m: None) -> Any:
        found = self.find(spec, seed)
        if found is not None:
            log(f"{name}: in {self.path} already (code {self.version}), skipped")
            return found["result"]
        t0, c0 = time.perf_counter(), time.process_time()
        result = finite(to_jsonable(fn()))
        self._append({"key": run_key(spec, seed, self.version), "name": name, "spec": to_jsonable(spec),
                      "seed": int(seed), "code_version": self.version, "wall_s": round(time.perf_counter() - t0, 2),
                      "cpu_s": round(time.process_time() - c0, 2), "finished_at": _now(), "result": result})
        self.computed += 1
        log(f"{name}: done in {self.runs[-1]['wall_s']:.0f} s wall, appended to {self.path}")
        return result

    def _append(self, row: dict[str, Any]) -> None:
        if self.data["code_version"] != self.version:  # first run of new code: the old ones are a record
            self.data["superseded"] = self.data["superseded"] + self.runs
            self.data["runs"] = []
            self.data["code_version"] = self.version
            self.data["science"], self.data["science_files"] = self.science, self.hashes
        self.data["runs"].append(row)
        self.save()

    def save(self) -> None:
        if self.path is not None:
            write_json_atomic(self.path, self.data)


def current_runs(data: dict[str, Any]) -> list[dict[str, Any]]:
    """The runs a renderer may use: those of the file's code version."""
    return [r for r in data.get("runs", []) if r.get("code_version") == data.get("code_version")]


def results_by_name(data: dict[str, Any]) -> dict[str, Any]:
    """{run name: result} of the current runs (the last one wins)."""
    return {r["name"]: r["result"] for r in current_runs(data)}


def merge(into: Path, other: Path) -> int:
    """Add to the ledger file ``into`` the runs of ``other`` (another machine's copy of the
    same experiment at the same code version) that it lacks; returns how many were added."""
    a, b = json.loads(Path(into).read_text()), json.loads(Path(other).read_text())
    if a.get("experiment") != b.get("experiment") or a.get("code_version") != b.get("code_version"):
        raise ValueError(f"cannot merge {other} into {into}: experiment or code version differs "
                         f"({b.get('experiment')}/{b.get('code_version')} vs {a.get('experiment')}/{a.get('code_version')})")
    have = {r["key"] for r in a["runs"]}
    new = [r for r in b["runs"] if r["key"] not in have]
    a["runs"] = a["runs"] + new
    write_json_atomic(Path(into), a)
    return len(new)


def machine_time(data: dict[str, Any]) -> dict[str, float]:
    """Wall and CPU seconds the current runs took, summed (what a reproduction cost)."""
    rs = current_runs(data)
    return {"runs": len(rs), "wall_s": round(sum(r.get("wall_s", 0.0) for r in rs), 1),
            "cpu_s": round(sum(r.get("cpu_s", 0.0) for r in rs), 1)}

"""`gaitmend docs-stale`: every committed reproduction ledger under docs/ whose data is older
than its science files (issue 45), with the files changed since and the command that re-runs
it; exit 1 when any is. The pages say the same in their generated ``data-age-*`` banner
(app/results/data_age.py, written by `gaitmend docs`).

``--record-from-git`` fills in ``science_files`` (each science file's hash at the recorded
code version) for a ledger written before the ledger kept them: it looks for the newest
commit whose science files hash to the ledger's ``code_version`` and takes their hashes
there, so the banner can name the files changed since; a ledger no commit matches is left
as it is (its banner says which files changed is not recorded)."""

from __future__ import annotations

import hashlib
import json
import subprocess
from pathlib import Path

import typer

from app.cli.common import cli
from app.jobs.ledger import ROOT, code_version, file_hashes, write_json_atomic
from app.results.data_age import is_ledger, stale


def _ledgers(root: Path = ROOT) -> list[str]:
    out = []
    for f in sorted((root / "docs").glob("*.json")):
        try:
            if is_ledger(json.loads(f.read_text())):
                out.append(str(f.relative_to(root)))
        except ValueError:
            continue
    return out


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], check=True, capture_output=True, text=True).stdout


def _hashes_at(commit: str, science: list[str]) -> tuple[str, dict[str, str]] | None:
    """(code_version, {file: hash}) of ``science`` as it was at ``commit`` (a folder: its
    *.py files), or None when a path did not exist there."""
    files: set[str] = set()
    for p in science:
        listed = _git("ls-tree", "-r", "--name-only", commit, "--", p).split()
        exact = [f for f in listed if f == p]
        found = exact or [f for f in listed if f.startswith(p.rstrip("/") + "/") and f.endswith(".py")]
        if not found:
            return None
        files.update(found)
    h, per = hashlib.sha256(), {}
    for rel in sorted(files):
        blob = subprocess.run(["git", "-C", str(ROOT), "show", f"{commit}:{rel}"], check=True,
                              capture_output=True).stdout
        h.update(rel.encode() + b"\0" + blob + b"\0")
        per[rel] = hashlib.sha256(blob).hexdigest()[:12]
    return h.hexdigest()[:12], per


def record_from_git(path: str, max_commits: int = 300) -> str | None:
    """Fill ``science_files`` of the ledger ``path`` from the newest commit whose science
    hashes to its code version; the commit, or None when none does."""
    f = ROOT / path
    data = json.loads(f.read_text())
    if data.get("science_files"):
        return "recorded already"
    try:
        current = code_version(data["science"]) == data["code_version"]
    except FileNotFoundError:  # a science file is gone: not current
        current = False
    if current:  # current: today's files are its files
        data["science_files"] = file_hashes(data["science"])
        write_json_atomic(f, data)
        return "current files"
    commits = _git("log", f"-{max_commits}", "--format=%H", "--", *data["science"], path).split()
    for c in commits:
        got = _hashes_at(c, data["science"])
        if got and got[0] == data["code_version"]:
            data["science_files"] = got[1]
            write_json_atomic(f, data)
            return c
    return None


@cli.command("docs-stale")
def docs_stale(record_from_git_: bool = typer.Option(False, "--record-from-git",
                                                      help="fill in the science files' hashes of ledgers that lack "
                                                           "them from the commit their code version matches")):
    """List every committed data file under docs/ older than its science files (exit 1 when
    any is): the files changed since, and the command that re-runs it."""
    paths = _ledgers()
    if record_from_git_:
        for p in paths:
            print(f"{p}: {record_from_git(p) or 'no commit matches its code version'}")
    items = stale(paths)
    for p, data, s in items:
        changed = "not recorded" if s["changed"] is None else ", ".join(s["changed"])
        print(f"{p}: code {s['recorded']}, now {s['now']}; changed since: {changed}; re-run: {data.get('command')}")
    print(f"{len(items)} of {len(paths)} data files are older than their science files")
    if items:
        raise typer.Exit(1)

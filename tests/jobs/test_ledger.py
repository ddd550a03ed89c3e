"""app/jobs/ledger.py: a reproduction appends each finished run to its JSON as it ends, a
re-run skips the runs there (keyed by spec + seed + the code version of the science), a
reproduction killed midway continues where it stopped with the same numbers, new code
re-runs everything (the old runs kept as a record), and two machines' copies merge."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from app.jobs import ledger
from app.jobs.ledger import Ledger, code_version, current_runs, finite, merge, run_key

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def science(tmp_path):
    """A repository-like root with one science module."""
    (tmp_path / "sci").mkdir()
    (tmp_path / "sci" / "model.py").write_text("K = 1\n")
    return tmp_path


def _ledger(path, root, planned=3):
    return Ledger(path, "toy", "gaitmend reproduce toy", {"n": planned}, ["sci"], planned=planned, root=root)


def test_runs_are_appended_and_skipped(science, tmp_path):
    path = tmp_path / "docs" / "toy.json"
    calls = []
    led = _ledger(path, science)
    for s in range(3):
        assert led.run(f"seed {s}", {"x": s}, s, lambda s=s: calls.append(s) or {"y": s * s}) == {"y": s * s}
        assert len(json.loads(path.read_text())["runs"]) == s + 1  # on disk as soon as it ends
    again = _ledger(path, science)
    assert [again.run(f"seed {s}", {"x": s}, s, lambda: pytest.fail("recomputed")) for s in range(3)] == \
        [{"y": 0}, {"y": 1}, {"y": 4}]
    assert calls == [0, 1, 2] and again.computed == 0
    data = json.loads(path.read_text())
    assert data["planned"] == 3 and data["code_version"] == code_version(["sci"], science)
    assert {"key", "name", "spec", "seed", "code_version", "wall_s", "cpu_s", "finished_at", "result"} <= set(data["runs"][0])
    assert oct(path.stat().st_mode & 0o777) != oct(0o600)  # readable by others, unlike mkstemp's file
    assert not [p for p in path.parent.iterdir() if p.name.endswith(".tmp")]


def test_the_key_is_spec_seed_and_code_version():
    k = run_key({"a": 1}, 0, "v1")
    assert k == run_key({"a": 1}, 0, "v1")
    assert len({k, run_key({"a": 2}, 0, "v1"), run_key({"a": 1}, 1, "v1"), run_key({"a": 1}, 0, "v2")}) == 4


def test_new_science_reruns_and_keeps_the_old_runs_as_a_record(science, tmp_path):
    path = tmp_path / "toy.json"
    _ledger(path, science).run("seed 0", {"x": 0}, 0, lambda: {"y": 1})
    (science / "sci" / "model.py").write_text("K = 2\n")  # the science changed
    led = _ledger(path, science)
    assert led.run("seed 0", {"x": 0}, 0, lambda: {"y": 2}) == {"y": 2} and led.computed == 1
    data = json.loads(path.read_text())
    assert [r["result"] for r in current_runs(data)] == [{"y": 2}]
    assert [r["result"] for r in data["superseded"]] == [{"y": 1}]
    # a file not yet rewritten by new code still renders its own version's runs only
    assert current_runs({"code_version": "a", "runs": [{"code_version": "a"}, {"code_version": "b"}]}) == \
        [{"code_version": "a"}]


def test_presentation_is_not_science(science):
    (science / "present.py").write_text("x = 1\n")
    v = code_version(["sci"], science)
    (science / "present.py").write_text("x = 2\n")
    assert code_version(["sci"], science) == v
    with pytest.raises(FileNotFoundError):
        code_version(["nowhere.py"], science)


def test_non_finite_numbers_are_stored_as_null(science, tmp_path):
    path = tmp_path / "toy.json"
    out = _ledger(path, science).run("r", {}, 0, lambda: {"a": float("nan"), "b": [1.0, float("inf")]})
    assert out == {"a": None, "b": [1.0, None]} == json.loads(path.read_text())["runs"][0]["result"]
    assert finite({"x": [float("-inf"), 2]}) == {"x": [None, 2]}


def test_two_machines_copies_merge(science, tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    _ledger(a, science).run("seed 0", {"x": 0}, 0, lambda: {"y": 0})
    lb = _ledger(b, science)
    lb.run("seed 0", {"x": 0}, 0, lambda: {"y": 0})
    lb.run("seed 1", {"x": 1}, 1, lambda: {"y": 1})
    assert merge(a, b) == 1 and merge(a, b) == 0
    assert sorted(r["name"] for r in json.loads(a.read_text())["runs"]) == ["seed 0", "seed 1"]
    other = tmp_path / "c.json"
    other.write_text(json.dumps(json.loads(b.read_text()) | {"code_version": "zzz"}))
    with pytest.raises(ValueError):
        merge(a, other)


TOY = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from app.jobs.ledger import Ledger
    root, out, log = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    led = Ledger(out, "toy", "toy", {}, ["sci"], planned=6, root=root)
    def work(s):
        with log.open("a") as fh:
            fh.write(f"{s}\\n")
        time.sleep(0.4)
        return {"square": s * s, "half": s / 2}
    for s in range(6):
        led.run(f"seed {s}", {"x": s}, s, lambda s=s: work(s))
""")


def _toy(science, out, log):
    script = science / "toy.py"
    script.write_text(TOY)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, str(script), str(science), str(out), str(log)], env=env,
                            start_new_session=True)


def test_a_reproduction_killed_midway_continues_where_it_stopped(science, tmp_path):
    out, log = tmp_path / "docs" / "toy.json", tmp_path / "started.log"
    proc = _toy(science, out, log)
    t0 = time.time()
    while not (out.exists() and len(json.loads(out.read_text())["runs"]) >= 2):
        assert time.time() - t0 < 60 and proc.poll() is None, "the toy reproduction did not get going"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # no chance to clean up: the file must be whole anyway
    proc.wait()
    done = json.loads(out.read_text())["runs"]
    assert 2 <= len(done) < 6
    proc = _toy(science, out, log)
    assert proc.wait(timeout=60) == 0
    runs = json.loads(out.read_text())["runs"]
    assert [r["result"] for r in runs] == [{"square": s * s, "half": s / 2} for s in range(6)]
    assert runs[:len(done)] == done  # the finished runs are kept as they were
    started = [int(x) for x in log.read_text().split()]
    # every finished run ran once; only the run the kill interrupted ran twice
    assert sorted(set(started)) == list(range(6)) and len(started) <= 7
    assert all(started.count(s) == 1 for s in range(len(done)))


def test_the_root_is_the_repository(tmp_path):
    """ROOT is the checkout that holds the code, wherever the process runs: imported from a
    process whose working directory is elsewhere, it is the folder above tests/ (found here
    from this file), and a science file named relative to it is hashed from there (the
    version computed by hand: sha256 over name, NUL, bytes, NUL)."""
    repo = Path(__file__).resolve().parents[2]
    rel = "app/jobs/ledger.py"
    expected = hashlib.sha256(rel.encode() + b"\0" + (repo / rel).read_bytes() + b"\0").hexdigest()[:12]
    code = "from app.jobs import ledger; print(ledger.ROOT); print(ledger.code_version(['app/jobs/ledger.py']))"
    env = os.environ | {"PYTHONPATH": str(repo), "PYTHONDONTWRITEBYTECODE": "1"}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == [str(repo), expected]
    assert ledger.ROOT == repo


def test_a_science_file_moved_unchanged_keeps_every_code_version(tmp_path, monkeypatch):
    """A move (ledger.MOVED: a robot's module that became its folder's __init__.py) hashes
    the file under the path ledgers recorded, in that path's order: the version is the one
    before the move, a ledger naming the old path is current and finds the file, and once
    the bytes change the page names the file where it is now."""
    from app.jobs import ledger

    (tmp_path / "app/robots").mkdir(parents=True)
    old, new = tmp_path / "app/robots/bot.py", tmp_path / "app/robots/abot/__init__.py"
    old.write_text("K = 1\n")
    (tmp_path / "app/robots/b.py").write_text("Z = 2\n")  # after the new path, before the old one
    science = ["app/robots/bot.py", "app/robots/b.py"]
    before = ledger.code_version(science, tmp_path)
    hashes = ledger.file_hashes(science, tmp_path)
    new.parent.mkdir()
    old.rename(new)
    monkeypatch.setattr(ledger, "MOVED", {"app/robots/bot.py": "app/robots/abot/__init__.py"})
    monkeypatch.setattr(ledger, "_RECORDED", {"app/robots/abot/__init__.py": "app/robots/bot.py"})
    moved = ["app/robots/abot/__init__.py", "app/robots/b.py"]
    assert ledger.code_version(moved, tmp_path) == before == ledger.code_version(science, tmp_path)
    assert ledger.file_hashes(moved, tmp_path) == hashes
    data = {"code_version": before, "science": science, "science_files": hashes}
    assert ledger.staleness(data, tmp_path) is None
    new.write_text("K = 2\n")
    assert ledger.staleness(data, tmp_path)["changed"] == ["app/robots/abot/__init__.py"]

"""scripts/loadtest.py --json-out and the section it feeds (issue 28): each submission-latency
measurement is appended to a JSON file with its options, the machine, the load before and
after, the niceness, the commit and the date, and docs/benchmarks.md's ``loadtest`` section
shows the latest run per database, counting the earlier ones. The renderer from fixture
rows; the script for real, at a tiny size, on SQLite with the server it starts itself."""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

from app.results import loadtest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "loadtest.py"


def _row(database: str, p50: float, date: str, commit: str = "0123456789abcdef", load=(3.94, 4.26)) -> dict:
    return {"clients": 50, "per_client": 10, "database": database, "requests": 500, "errors": 0, "first_error": [],
            "p50_ms": p50, "p99_ms": 612.34, "max_ms": 700.0, "mean_ms": 250.0, "throughput_per_s": 148.26,
            "machine": {"cpu": "Test CPU", "cores": 2, "python": "3.11"}, "load_before": load[0],
            "load_after": load[1], "nice": 10, "commit": commit, "date": date, "wall_s": 9.1}


FIXTURE = {"schema": 1, "experiment": "loadtest", "command": loadtest.COMMAND, "runs": [
    _row("sqlite", 999.9, "2026-12-01 10:00 UTC"),
    _row("postgresql://127.0.0.1:5432", 321.0, "2026-12-02 10:00 UTC"),
    _row("sqlite", 234.56, "2026-12-03 17:00 UTC", commit="fedcba9876543210+dirty", load=(0.5, 1.21)),
]}
HEAD = ("| database | p50 | p99 | max | throughput | failures | clients x requests | load before / after | machine "
        "| commit | finished |\n|" + "---|" * 11 + "\n")


def test_the_latest_run_per_database_in_the_order_first_measured():
    text = loadtest.render(FIXTURE)
    assert text.startswith(
        HEAD + "| sqlite | 234.6 ms | 612.3 ms | 700.0 ms | 148.3/s | 0 | 50 x 10 | 0.5 / 1.2 | Test CPU, 2 cores, nice 10 "
          "| fedcba9876 (uncommitted changes) | 2026-12-03 17:00 UTC |\n"
          "| postgresql://127.0.0.1:5432 | 321.0 ms | 612.3 ms | 700.0 ms | 148.3/s | 0 | 50 x 10 | 3.9 / 4.3 "
          "| Test CPU, 2 cores, nice 10 | 0123456789 | 2026-12-02 10:00 UTC |\n\n")
    assert "999.9" not in text  # the earlier SQLite run: kept in the file, counted, not shown
    assert text.endswith("1 earlier run kept in [loadtest.json](loadtest.json), not shown.\n")
    assert "only submission is timed" in text


def test_earlier_runs_are_counted_and_a_missing_file_names_its_command():
    two_more = {"runs": [*FIXTURE["runs"], _row("sqlite", 1.0, "2026-12-04 10:00 UTC")]}
    assert loadtest.render(two_more).endswith("2 earlier runs kept in [loadtest.json](loadtest.json), not shown.\n")
    assert loadtest.render({"runs": FIXTURE["runs"][1:2]}).endswith("0 earlier runs kept in [loadtest.json]"
                                                                    "(loadtest.json), not shown.\n")
    expected = "*No data yet: `python scripts/loadtest.py --json-out docs/loadtest.json` writes docs/loadtest.json.*\n"
    assert loadtest.render(None) == expected and loadtest.render({"runs": []}) == expected


def test_a_postgresql_url_is_kept_with_its_host_only():
    spec = importlib.util.spec_from_file_location("loadtest_script", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)

    def db(url: str = "", server: str | None = None) -> str:
        return script.database(argparse.Namespace(database_url=url, server=server))

    assert db("postgresql://postgres:secret@127.0.0.1:5432/test?x=1") == "postgresql://127.0.0.1:5432"
    assert db("postgresql+psycopg://u@db.example") == "postgresql+psycopg://db.example"
    assert db() == "sqlite" and db("sqlite:////tmp/x.db") == "sqlite"
    assert db(server="http://h:8000") == "unknown (--server http://h:8000)"


def _loadtest(out: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")} | {"PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, str(SCRIPT), "--clients", "2", "--per-client", "3", "--json-out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def test_the_script_appends_each_measurement_with_where_and_when(tmp_path):
    out = tmp_path / "loadtest.json"
    printed = _loadtest(out)
    data = json.loads(out.read_text())
    assert (data["schema"], data["experiment"], data["command"]) == (1, "loadtest", loadtest.COMMAND)
    [row] = data["runs"]
    assert row == printed
    assert (row["clients"], row["per_client"], row["database"], row["requests"], row["errors"]) == (2, 3, "sqlite", 6, 0)
    assert 0 < row["p50_ms"] <= row["p99_ms"] <= row["max_ms"] and row["throughput_per_s"] > 0
    assert row["machine"]["cores"] == os.cpu_count() and row["machine"]["cpu"]
    assert isinstance(row["load_before"], float) and isinstance(row["load_after"], float)
    assert row["nice"] == os.nice(0) and row["wall_s"] > 0
    assert row["commit"].removesuffix("+dirty") == subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, text=True,
                                                                  capture_output=True).stdout.strip()
    assert row["date"].endswith(" UTC")

    _loadtest(out)
    runs = json.loads(out.read_text())["runs"]
    assert len(runs) == 2 and runs[0] == row
    assert loadtest.render({"runs": runs}).endswith("1 earlier run kept in [loadtest.json](loadtest.json), not shown.\n")

"""Submission latency under load, rendered from docs/loadtest.json (issue 28: every published
number from committed data). ``python scripts/loadtest.py --json-out docs/loadtest.json``
appends each measurement with its options (clients, requests per client, the database), the
machine, the 1-minute load average before and after, the niceness, the commit and the date
(app/cli/bench.py ``measured`` and ``append_measured``); ``loadtest`` is docs/benchmarks.md's
table of the latest run per database. Earlier runs stay in the file and are counted."""

from __future__ import annotations

from app.core.host import machine_text
from app.jobs.reporting import Section, md_table, missing
from app.results.benchmarks import load_text
from app.results.examples import commit_text

JSON = "docs/loadtest.json"
COMMAND = "python scripts/loadtest.py --json-out docs/loadtest.json"
COLUMNS = ["database", "p50", "p99", "max", "throughput", "failures", "clients x requests", "load before / after",
           "machine", "commit", "finished"]


def latest(data: dict | None) -> list[dict]:
    """The latest run against each database, in the order the databases were first measured."""
    out: dict[str, dict] = {}
    for r in (data or {}).get("runs", []):
        out[r["database"]] = r
    return list(out.values())


def _row(r: dict) -> list[str]:
    m = r["machine"]
    return [r["database"], f"{r['p50_ms']:.1f} ms", f"{r['p99_ms']:.1f} ms", f"{r['max_ms']:.1f} ms",
            f"{r['throughput_per_s']:.1f}/s", str(r["errors"]), f"{r['clients']} x {r['per_client']}", load_text(r),
            f"{machine_text(m)}, nice {r['nice']}", commit_text(r), r["date"]]


def render(data: dict | None) -> str:
    """The latest run per database, what is measured, and how many earlier runs the file keeps."""
    shown = latest(data)
    if not shown:
        return missing(JSON, COMMAND)
    earlier = len(data["runs"]) - len(shown)
    name = JSON.split("/")[-1]
    return (md_table(COLUMNS, [_row(r) for r in shown])
            + "\nEach row is the latest run against its database: the clients, each with its own connection, "
              "POST /api/jobs concurrently, each its requests one after another (a registered kind's smoke spec, "
              "distinct seeds), to a `gaitmend serve` the script starts (embedded broker, no worker, so jobs stay "
              "queued and only submission is timed); p50, p99 and max are of one request's time, throughput is the "
              "requests over the burst's wall time, at the 1-minute load shown. "
              f"{earlier} earlier run{'' if earlier == 1 else 's'} kept in [{name}]({name}), not shown.\n")


def sections() -> tuple[Section, ...]:
    return (Section("loadtest", (JSON,), lambda d: render(d[0])),)

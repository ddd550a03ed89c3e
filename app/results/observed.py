"""What the test suite observes, rendered from docs/observed.json (issue 28: every published
number from committed data, also the ones only a test measures).

Some figures exist only inside tests against the real services: how soon the queue moves
after Redis returns, how long a stopped worker takes to exit, how soon a killed worker's
job is claimed again, how long the dashboard takes to draw its first plot, how long the
suite itself runs. A test hands each to ``record``; with ``GAITMEND_OBSERVED`` naming a JSON
file (outside the checkout: the suite writes nothing into it), the figure is appended there
with the test, the machine, the 1-minute load average, the niceness, the commit and the
date; without it ``record`` does nothing, so CI's runs write nothing. Several pytest-xdist
workers append to one file under a lock. To publish a run::

    cp docs/observed.json /tmp/observed.json
    GAITMEND_OBSERVED=/tmp/observed.json bash scripts/test.sh
    cp /tmp/observed.json docs/observed.json && gaitmend docs

The pages show each figure's latest run (``observed-faults`` in docs/faults.md,
``observed-service`` in docs/benchmarks.md); earlier runs stay in the file and are counted."""

from __future__ import annotations

import datetime as _dt
import fcntl
import json
import math
import os
from pathlib import Path
from typing import Any

from app.core.host import machine, machine_text
from app.jobs.reporting import Section, md_table
from app.results.examples import commit_text
from app.results.provenance import git_commit

JSON = "docs/observed.json"
ENV = "GAITMEND_OBSERVED"
COMMAND = "GAITMEND_OBSERVED=/tmp/observed.json bash scripts/test.sh"
ROOT = Path(__file__).resolve().parents[2]

# figure -> (what it is, the unit, the page's group); a figure not declared here is refused,
# so a page never shows a name nobody explained
FIGURES: dict[str, tuple[str, str, str]] = {
    "faults.redis_queue_moved_s": ("Redis restarted: from its return to the first job started", "s", "faults"),
    "faults.stop_worker_exit_s": ("`docker stop` (SIGTERM) of a worker running a job: until it exited", "s", "faults"),
    "faults.stop_term_ran_elsewhere_s": ("SIGTERM: until the job ran on another worker", "s", "faults"),
    "faults.stop_term_kill_ran_elsewhere_s": ("SIGTERM, then SIGKILL once the stop was recorded: until the job "
                                              "ran on another worker", "s", "faults"),
    "faults.pg_backends_per_burst": ("PostgreSQL backends terminated per burst", "", "faults"),
    "worker.kill9_embedded_resume_s": ("`kill -9` of the whole worker mid-search, embedded broker: until the "
                                       "job was claimed again", "s", "service"),
    "worker.kill9_embedded_done_s": ("the same: until the job finished", "s", "service"),
    "worker.kill9_redis_resume_s": ("`kill -9` of the whole worker mid-search, Redis + PostgreSQL: until the "
                                    "job was claimed again", "s", "service"),
    "worker.kill9_redis_done_s": ("the same: until the job finished", "s", "service"),
    "dashboard.first_plot_s": ("dashboard: from submit to the job page's first convergence plot", "s", "service"),
    "dashboard.jobs_first_page_s": ("jobs list of 3000 jobs: the first page (page load included)", "s", "service"),
    "dashboard.jobs_older_page_s": ("jobs list of 3000 jobs: one older page", "s", "service"),
    "dashboard.cold_verdict_ms": ("a cold job page (fresh browser context; recovery: the convergence plot and "
                                  "three panels), its second load: navigation start to the verdict", "ms", "service"),
    "dashboard.cold_drawn_ms": ("the same load: navigation start to every plot drawn", "ms", "service"),
    "dashboard.cold_first_load_drawn_ms": ("its first load (the server computes the views once per bundle): to "
                                           "every plot drawn", "ms", "service"),
    "dashboard.plotly_cartesian_gzip_bytes": ("plotly's cartesian bundle over the wire, gzipped (what a recovery "
                                              "page loads)", "bytes", "service"),
    "dashboard.plotly_full_bytes": ("the full `plotly.min.js`, uncompressed", "bytes", "service"),
    "dashboard.plotly_full_gzip_bytes": ("the full `plotly.min.js` over the wire, gzipped", "bytes", "service"),
    "robots.hostile_api_peak_rss_growth_mb": ("the hostile-robot suite through the API: growth of the API "
                                              "process's peak resident memory", "MB", "service"),
    "suite.parallel_s": ("the suite's parallel part (scripts/test.sh)", "s", "service"),
    "suite.serial_s": ("the suite's serial part, the fault tests (scripts/test.sh)", "s", "service"),
}


def _check(figure: str, values: list[float]) -> list[float]:
    if figure not in FIGURES:
        raise ValueError(f"observed figure {figure!r} is not declared in app/results/observed.py FIGURES")
    if not values or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                             for v in values):
        raise ValueError(f"observed figure {figure!r}: values must be a non-empty list of finite numbers, "
                         f"got {values!r}")
    return [float(v) for v in values]


def record(figure: str, values: list[float], setup: dict[str, Any] | None = None, path: str | None = None) -> bool:
    """Append ``values`` of ``figure`` (with ``setup``: the test's parameters that frame them)
    to the file ``GAITMEND_OBSERVED`` names; False (nothing written) when it names none."""
    values = _check(figure, values)
    target = path or os.environ.get(ENV, "").strip()
    if not target:
        return False
    target_path = Path(target)
    if ROOT in target_path.resolve().parents:
        raise ValueError(f"{ENV}={target!r} is inside the checkout; name a file outside it and copy it to {JSON}")
    row = {"figure": figure, "values": values, "setup": setup or {},
           "test": os.environ.get("PYTEST_CURRENT_TEST", "").split(" (")[0], "machine": machine(),
           "load": os.getloadavg()[0], "nice": os.nice(0), "commit": git_commit(ROOT),
           "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    target_path.parent.mkdir(parents=True, exist_ok=True)
    with open(f"{target_path}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # pytest-xdist workers append to one file
        data = json.loads(target_path.read_text()) if target_path.exists() else {"schema": 1, "runs": []}
        data["runs"].append(row)
        tmp = target_path.with_name(f".{target_path.name}.tmp")
        tmp.write_text(json.dumps(data, indent=1) + "\n")
        os.replace(tmp, target_path)
    return True


def latest(data: dict | None) -> dict[str, dict]:
    """figure -> its latest run, in FIGURES' order."""
    last: dict[str, dict] = {}
    for r in (data or {}).get("runs", []):
        last[r["figure"]] = r
    return {f: last[f] for f in FIGURES if f in last}


def _number(v: float, unit: str) -> str:
    if unit == "bytes":
        return f"{v / 1e6:.2f} MB" if v >= 1e6 else f"{v / 1e3:.0f} kB"
    text = f"{v:.0f}" if float(v).is_integer() and unit == "" else f"{v:.1f}"
    return f"{text} {unit}".strip()


def spread(run: dict) -> str:
    """'lo-hi unit (n values)' of a run, or its one value."""
    unit = FIGURES[run["figure"]][1]
    vs = run["values"]
    if len(vs) == 1:
        return _number(vs[0], unit)
    lo, hi = _number(min(vs), unit), _number(max(vs), unit)
    return f"{lo.removesuffix(' ' + unit) if unit else lo}-{hi} ({len(vs)} values)"


def _setup(run: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in run["setup"].items()) or "-"


def render(data: dict | None, group: str) -> str:
    """The latest run of each figure of ``group``: its values, the test, where and when."""
    shown = {f: r for f, r in latest(data).items() if FIGURES[f][2] == group}
    if not shown:
        return (f"*No data yet: `{COMMAND}` (from a copy of {JSON}, copied back afterwards) records "
                f"these figures.*\n")
    rows = [[f"`{f}`", FIGURES[f][0], spread(r), _setup(r), f"`{r['test'] or '-'}`",
             f"{machine_text(r['machine'])}, nice {r['nice']}, load {r['load']:.1f}",
             commit_text(r), r["date"]] for f, r in shown.items()]
    earlier = sum(1 for r in data["runs"] if FIGURES.get(r["figure"], ("", "", ""))[2] == group) - len(shown)
    name = JSON.split("/")[-1]
    return (md_table(["figure", "what", "observed (latest run)", "set-up", "test", "machine, load", "commit",
                      "finished"], rows)
            + f"\nRecorded by the tests named, with `{ENV}` set (app/results/observed.py); the load is the 1-minute "
              f"load average as the figure was recorded (other tests run beside them in the parallel part). "
              f"{earlier} earlier record{'' if earlier == 1 else 's'} kept in [{name}]({name}), not shown.\n")


def sections() -> tuple[Section, ...]:
    return (Section("observed-faults", (JSON,), lambda d: render(d[0], "faults")),
            Section("observed-service", (JSON,), lambda d: render(d[0], "service")))

"""How long the README's example lines take, rendered from docs/readme_examples.json (issue
28: every published number from committed data). ``gaitmend reproduce readme-examples``
(app/cli/examples.py) reads the lines from README.md, runs each as written and appends its
wall and CPU seconds with the machine, the 1-minute load before and after, the commit and
the date. ``whole-jobs`` is docs/benchmarks.md's table (the latest run of each example);
``readme-examples-time`` is the README's sentence on how long they take."""

from __future__ import annotations

from app.core.host import machine_text
from app.jobs.reporting import Section, md_table, missing

JSON = "docs/readme_examples.json"
COMMAND = "gaitmend reproduce readme-examples --write-docs"


FIRST_KEY = "first-command"  # app/cli/examples.py: the README's first command's job


def latest(data: dict | None, first: bool = True) -> list[dict]:
    """The latest run of each example (by its spec's key), in the order the examples were
    first measured; ``first=False`` leaves out the first command's job."""
    out: dict[str, dict] = {}
    for r in (data or {}).get("runs", []):
        if first or r["key"] != FIRST_KEY:
            out[r["key"]] = r
    return list(out.values())


def duration(s: float) -> str:
    """Seconds under ten minutes as seconds, longer as minutes."""
    return f"{s:.0f} s" if s < 600 else f"{s / 60:.1f} min"


def commit_text(run: dict) -> str:
    """A run's commit, short, and whether the tree had uncommitted changes."""
    c = run.get("commit") or "unknown"
    return c[:10] + (" (uncommitted changes)" if c.endswith("+dirty") else "")


def render_table(data: dict | None) -> str:
    """docs/benchmarks.md's whole-jobs table: each example, its wall and CPU time, its load."""
    runs = latest(data)
    if not runs:
        return missing(JSON, COMMAND)
    rows = [[r["kind"] + (" (the first command)" if r["key"] == FIRST_KEY else ""),
             f"`{r['command'] if r['key'] == FIRST_KEY else r['spec']}`", duration(r["wall_s"]), duration(r["cpu_s"]),
             f"{r['load_before']:.1f} / {r['load_after']:.1f}", r["date"], commit_text(r)] for r in runs]
    machines = sorted({f"{machine_text(r['machine'])}, nice {r['nice']}" for r in runs})
    return (md_table(["kind", "spec", "wall", "CPU", "load before / after", "finished", "commit"], rows)
            + f"\nEach line as the README shows it, run alone, on {'; '.join(machines)}. Wall: the whole command "
              f"(start-up, search, controls, robustness re-runs, bundle), at the 1-minute load shown; CPU: the "
              f"command's processes together. Earlier runs stay in [{JSON.split('/')[-1]}]"
              f"({JSON.split('/')[-1]}).\n")


def render_sentence(data: dict | None) -> str:
    """The README's sentence: the range of the examples' wall times and the load they carry."""
    runs = latest(data, first=False)
    if not runs:
        return missing(JSON, COMMAND)
    walls = [r["wall_s"] for r in runs]
    loads = [x for r in runs for x in (r["load_before"], r["load_after"])]
    cores = sorted({r["machine"]["cores"] for r in runs})
    each = ", ".join(f"{r['kind']} {duration(r['wall_s'])}" for r in runs)
    return (f"Each took {duration(min(walls))} to {duration(max(walls))} ({each}) on "
            f"{'/'.join(map(str, cores))} shared cores at a 1-minute load of {min(loads):.1f}-{max(loads):.1f} "
            f"([docs/benchmarks.md](docs/benchmarks.md#whole-jobs)).\n")


def sections() -> tuple[Section, ...]:
    return (Section("whole-jobs", (JSON,), lambda d: render_table(d[0])),
            Section("readme-examples-time", (JSON,), lambda d: render_sentence(d[0])))

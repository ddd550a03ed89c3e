"""The benchmark figures of docs/benchmarks.md and of each kind's page, rendered from
docs/benchmarks.json (issue 28: every published number from committed data). That file is
written by ``gaitmend reproduce bench`` (app/cli/bench.py), which runs ``gaitmend bench
--kind K --json`` for each kind and appends the kind's figures with the machine, the
1-minute load average before and after, the commit and the date.

The renderers know no kind: a kind's figures are its bench entries' JSON, shown as the
bench returns them (a number with the unit its key ends in), each with the target and the
verdict the bench reports in its ``targets`` block: ``<figure>_max`` / ``<figure>_min``
bound the figure of that name, and its verdict is the ``<stem>_met`` whose stem is the
longest that begins the figure's name (``ga_wall_s_max`` -> ``ga_met``). A figure the
bench gives no target has none here. Lists (e.g. each run of a preset) stay in the JSON.

Rows of kind ``studies`` are `gaitmend bench --studies --json` (`gaitmend reproduce bench
--kinds studies`): a study's dispatch overhead per point, with the deployment it ran on;
``study-dispatch`` is docs/studies.md's section of the latest one."""

from __future__ import annotations

import re
from typing import Any

from app.core.host import machine_text
from app.jobs.registry import KINDS
from app.jobs.reporting import Section, md_table, missing
from app.results.examples import commit_text

JSON = "docs/benchmarks.json"
COMMAND = "gaitmend reproduce bench --write-docs"
STUDIES = "studies"  # the kind of `gaitmend bench --studies` rows (no kind of the registry)
STUDIES_COMMAND = f"gaitmend reproduce bench --kinds {STUDIES} --write-docs"
ADAPT = "adapt"  # the kind of `gaitmend bench --adapt` rows (an adaptation session is no job kind)
ADAPT_COMMAND = f"gaitmend reproduce bench --kinds {ADAPT} --write-docs"
SKIP = ("targets",)  # the verdicts, shown beside their figures
PER = re.compile(r"_(ms|s)_per_([a-z]+)$")  # a time per something else
UNITS = (("_per_s", "/s"), ("_ms", "ms"), ("_s", "s"), ("_cm", "cm"), ("_deg", "deg"), ("_m", "m"))


def runs_of(data: dict | None, kind: str) -> list[dict]:
    """The runs of ``kind`` in the file, oldest first."""
    return [r for r in (data or {}).get("runs", []) if r["kind"] == kind]


def flat(figures: dict, prefix: str = "", nested: bool = True) -> list[tuple[str, Any]]:
    """(dotted key, value) of every scalar of ``figures`` in order (a dict's scalars under
    its key when ``nested``; lists and the targets block left out)."""
    out: list[tuple[str, Any]] = []
    for k, v in figures.items():
        if k in SKIP or isinstance(v, list):
            continue
        if isinstance(v, dict):
            out += flat(v, f"{prefix}{k}.", nested) if nested else []
        else:
            out.append((prefix + k, v))
    return out


def unit_of(key: str) -> str:
    """The unit the last part of a dotted key that has one ends in (``parts_s.qp``: s;
    ``rollout_s_per_generation``: s per generation)."""
    for part in reversed(key.split(".")):
        per = PER.search(part)
        if per:
            return f"{dict(UNITS)['_' + per[1]]} per {per[2]}"
        unit = next((u for suffix, u in UNITS if part.endswith(suffix)), "")
        if unit:
            return unit
    return ""


def value(key: str, v: Any) -> str:
    """A figure as text: the number to about three digits, with its key's unit."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, str):
        return v
    unit = unit_of(key)
    a = abs(v)
    text = (f"{v:,}" if isinstance(v, int) else f"{v:,.0f}" if a >= 100 else f"{v:.1f}" if a >= 10
            else f"{v:.2f}" if a >= 1 else f"{v:.3g}")
    return f"{text} {unit}".strip()


def verdicts(figures: dict) -> dict[str, tuple[str, bool | None]]:
    """{figure key: (its target in words, met as the bench reports it, None if it does not)}."""
    targets = figures.get("targets") or {}
    mets = sorted((k[:-4] for k in targets if k.endswith("_met")), key=len, reverse=True)
    out = {}
    for k, bound in targets.items():
        for suffix, sign in (("_max", "<="), ("_min", ">=")):
            if k.endswith(suffix):
                key = k[:-len(suffix)]
                stem = next((m for m in mets if key.startswith(m)), None)
                met = None if stem is None else targets[f"{stem}_met"]
                out[key] = (f"{sign} {bound:g} {unit_of(key)}".strip(), met)
    return out


def met_text(met: bool | None) -> str:
    return "-" if met is None else "met" if met else "**not met**"


def load_text(run: dict) -> str:
    return f"{run['load_before']:.1f} / {run['load_after']:.1f}"


def provenance(run: dict) -> str:
    """Where and when a run was measured, and at which load."""
    m = run["machine"]
    commit = run.get("commit") or "unknown"
    return (f"`gaitmend bench --kind {run['kind']} --json`, finished {run['date']}, commit {commit[:10]}"
            f"{' (with uncommitted changes)' if commit.endswith('+dirty') else ''}, {machine_text(m)}, "
            f"nice {run['nice']}; 1-minute load average {run['load_before']:.1f} before and {run['load_after']:.1f} "
            f"after (wall times carry that load); the bench took {value('wall_s', run['wall_s'])}.")


def kind_rows(run: dict, nested: bool) -> list[list[str]]:
    """[figure, measured, target, met] for every scalar figure of one run."""
    rows = []
    for entry, figures in run["figures"].items():
        judged = verdicts(figures)
        for key, v in flat(figures, nested=nested):
            target, met = judged.get(key, ("-", None))
            rows.append([f"`{entry}.{key}`", value(key, v), target, met_text(met)])
    return rows


def render_kind(kind: str, data: dict | None) -> str:
    """One kind's section: its latest run, every scalar figure, with where it was measured."""
    runs = runs_of(data, kind)
    if not runs:
        return missing(JSON, f"gaitmend reproduce bench --kinds {kind} --write-docs")
    run = runs[-1]
    earlier = (f" {len(runs) - 1} earlier run(s) of this kind are kept in {JSON}, not shown."
               if len(runs) > 1 else "")
    return md_table(["figure", "measured", "target", "met"], kind_rows(run, True)) + f"\n{provenance(run)}{earlier}\n"


def render_all(data: dict | None) -> str:
    """Every kind's latest run at a glance: its top-level figures, with the load each was measured at."""
    rows, notes = [], []
    for kind in KINDS:
        runs = runs_of(data, kind)
        if not runs:
            notes.append(f"{kind}: not measured yet (`gaitmend reproduce bench --kinds {kind} --write-docs`).")
            continue
        run = runs[-1]
        rows += [[kind, *r, load_text(run)] for r in kind_rows(run, False)]
        notes.append(f"{kind}: {provenance(run)}")
    if not rows:
        return missing(JSON, COMMAND)
    return (md_table(["kind", "figure", "measured", "target", "met", "load before / after"], rows) + "\n"
            + "".join(f"- {n}\n" for n in notes))


def render_studies(data: dict | None) -> str:
    """docs/studies.md's dispatch overhead: the latest `gaitmend bench --studies` run's
    figures, its verdict, its deployment and where and when it was measured."""
    runs = runs_of(data, STUDIES)
    if not runs:
        return missing(JSON, STUDIES_COMMAND)
    run = runs[-1]
    f, m, d = run["figures"]["study_dispatch"], run["machine"], run["deployment"]
    verdict = f"target <= {f['target_ms']:g} ms: {met_text(f['met'])}"
    rows = [["overhead per point, beside the jobs' own work (claim -> finish)",
             f"**{f['overhead_per_point_ms']:.1f} ms** ({verdict})"],
            ["overhead per point, beside the kinds' compute alone", f"{f['overhead_vs_kind_compute_ms']:.1f} ms"],
            ["wall, from the POST until the study finished", f"{f['wall_s']:.2f} s"],
            ["jobs' claim -> finish (sum)", f"{f['jobs_claim_to_finish_s']:.2f} s"],
            ["kinds' compute (sum)", f"{f['kind_compute_s']:.2f} s"],
            ["points", f"{f['points']} ({f['status']})"],
            ["deployment", f"broker {d['broker']}, database {d['database']}"],
            ["1-minute load average before / after", load_text(run)],
            ["machine", f"{machine_text(m)}, nice {run['nice']}"],
            ["commit", commit_text(run)],
            ["finished", run["date"]]]
    earlier = len(runs) - 1
    return (md_table(["figure", "measured"], rows)
            + f"\n`gaitmend bench --studies --json` as `{STUDIES_COMMAND}` ran it; {earlier} earlier "
              f"run{'' if earlier == 1 else 's'} kept in [benchmarks.json](benchmarks.json), not shown.\n")


def render_adapt(data: dict | None) -> str:
    """docs/adapt.md's speed: the latest `gaitmend bench --adapt` run's figures (the post of the
    last trial to a session over a large map, warm and after a restart), where and when."""
    runs = runs_of(data, ADAPT)
    if not runs:
        return missing(JSON, ADAPT_COMMAND)
    run = runs[-1]
    f = run["figures"]["adapt_proposal"]
    return (f"Posting trial {f['trials']} to a session over a map of {f['elites']:,} elites, through the API on "
            f"SQLite, took {f['warm_s']:.2f} s (best of {f['repeats']}; median {f['warm_median_s']:.2f} s) while the "
            f"server held the map, and {f['cold_s']:.2f} s as the first post after a restart, which reads the job's "
            f"stored result again. Target <= {f['target_s']:g} s for each of the {f['repeats']} posts: warm "
            f"{met_text(f['met'])}, after a restart {met_text(f['met_cold'])}. Measured by `{ADAPT_COMMAND}` "
            f"(`gaitmend bench --adapt --json`) on "
            f"{machine_text(run['machine'])}, nice {run['nice']}, 1-minute load average {load_text(run)}, "
            f"{commit_text(run)}, finished {run['date']}. The map is synthetic (random elites in the kind's result "
            "format): the cost depends on the map's size, not on its gaits.\n")


def sections() -> tuple[Section, ...]:
    """``bench`` (every kind at a glance, docs/benchmarks.md), ``bench-<kind>`` per kind with
    a bench (its page's machine-dependent section), ``study-dispatch`` (docs/studies.md) and
    ``bench-adapt`` (docs/adapt.md)."""
    per_kind = tuple(Section(f"bench-{k}", (JSON,), lambda d, k=k: render_kind(k, d[0]))
                     for k, kind in KINDS.items() if kind.bench())
    return (Section("bench", (JSON,), lambda d: render_all(d[0])), *per_kind,
            Section("study-dispatch", (JSON,), lambda d: render_studies(d[0])),
            Section("bench-adapt", (JSON,), lambda d: render_adapt(d[0])))

"""Issue 22's measurements (`gaitmend reproduce recovery-speed`): where a step's time goes,
what cutting short the walks that cannot win DE's selection saves and whether it leaves the
answer alone, the fast preset's time to the target, and a configuration of equal quality
for less. Every run is written to the JSON file as it finishes, so an interrupted
measurement resumes where it stopped; docs/recovery_speed.md is made from that file.

The measurements and the page are split by concern: speed_configs.py (what is compared),
speed_step.py (a step's cost), speed_runs.py (the searches and walks, stored as they
finish), speed_tables.py and speed_findings.py (the page's tables and comparisons); this
module assembles the page and re-exports the names the experiments, bench and tests use."""

from __future__ import annotations

import json
import statistics
from pathlib import Path

from app.core.host import machine_text
from app.jobs.reporting import marked, missing
# besides the page's parts, these re-export the names the experiments, the bench and the tests use
from app.jobs.recovery.reproduce.speed_configs import (ALTERNATIVES, EQUAL, PERTURBED_SETS, _documented, _table2_rows,
                                                       by_config)
from app.jobs.recovery.reproduce.speed_step import STEP_SETTINGS, scaling_markdown, scaling_row
from app.jobs.recovery.reproduce.speed_runs import PARTS, append_part, measure, perturbed_rows, throughput
from app.jobs.recovery.reproduce.speed_tables import (alternatives_markdown, cap_markdown, check_markdown,
                                                      coarse_markdown, control_markdown, profile_markdown,
                                                      runs_markdown, variants_markdown)
from app.jobs.recovery.reproduce.speed_findings import (gains_markdown, paired_markdown, perturbed_markdown,
                                                        short_markdown, summary_markdown)


TITLE = "# Recovery speed (issue 22)"
JSON, TABLE2_JSON = "docs/recovery_speed.json", "docs/table2.json"
SECTION, COMMAND = "recovery-speed", "gaitmend reproduce recovery-speed"
INTRO = """Measured by `gaitmend reproduce recovery-speed` (this page and recovery_speed.json; every
row is a run of this code, written as it finished). The machine was shared: wall times
and steps/s carry the load (1-minute load average on its 2 cores) they were measured at;
simulated steps do not depend on the machine, so the gains are stated in steps first.
`gaitmend bench --kind recovery --json` measures the issue's figures on one machine in one
go. Paper DE = DE 30 x 60, 10 s walks, 1 ms (here with `search.cut_walks`; for seeds the
docs hold, its answer is compared with the full-walk answer in docs/table2.json). Fast =
`{"preset": "fast"}`. Equal quality = the configuration below. Every search's answer is
also re-run at half the step (the robustness case dt_half); the searches here are not re-run
under perturbed friction or masses (a job's robustness block does that: docs/recovery_robust.md),
so this page claims speed and F at the default step, not robustness. The step changes
(contact pairs, islands, the fall sensor) are checked bit for bit in every world a job
builds, the perturbed ones included (tests/robots/test_contacts.py).
"""

RULE = """## Cut walks: the rule

DE keeps a trial only if its F is at least its parent's (Eq. 10). After each 1 s chunk of a
trial's walk, F is bounded from above: the roll and pitch amplitudes so far (they only grow
as the walk goes on) in the denominator, the drift and yaw terms at their least (0), and
the forward displacement so far plus the rest of the walk at `CUT_SPEED_FACTOR` times the
gait's nominal speed (step length per period). Once that bound is below the parent's F,
the walk stops and the bound is told to DE in place of F: the parent stays, as it would
after the full walk. The answer is the full-walk DE's whenever the speed cap holds; the
history's mean, worst and generation_best skip the bounds (column `cut` counts them). The
drift and yaw cannot bound F this way (they can shrink again), so a walk that only drifts
is never cut: the gain is largest on rocking two-leg walks and near zero where the body
barely rocks (leg 4 lost).

The random-search control (`controls.cut_walks`, on by default) uses the same bound against
its best so far: a uniform draw never depends on F, and only a walk above the best so far
changes the control's answer, so its best is the full-walk control's whenever the cap
holds. Most random walks fall short of a good gait within seconds, so here the rule saves
far more than in DE, whose trials are near their parents.
"""


def bench_markdown(row: dict) -> list[str]:
    """The issue's targets as `gaitmend bench --kind recovery --json` measured them."""
    f, t = row["figures"], row["figures"].get("targets", {})
    eq = f["equal_quality"]
    peer = {n: p["ratio_to_ours"] for n, p in f["peers"].items()}
    yes = {True: "met", False: "**not met**"}
    cells = [
        ("raw rollout / through the evaluator (steps/s)", f"{f['raw_steps_per_s']:,.0f} / "
         f"{f['evaluator_steps_per_s']:,.0f}, ratio {f['ratio']:.2f}", ">= 0.9", yes[t.get("ratio_met", False)]),
        ("exact paper DE (30 x 60, full 10 s walks), legs 1 & 6", f"{f['paper_recovery_wall_s']:.1f} s, F "
         f"{f['paper']['fitness']:.2f}, target {'met' if f['paper']['target_met'] else 'not met'}", "<= 120 s",
         yes[t.get("paper_recovery_met", False)]),
        ("fast preset: time to the target, 4 damages x 3 seeds", f"median {f['time_to_target_median_s']:.1f} s "
         f"[{f['fast']['time_to_target_s']['min']:.1f}, {f['fast']['time_to_target_s']['max']:.1f}], {f['fast']['reached']} "
         f"reached, all met at half the step: {f['fast']['all_met_at_half_step']}", "<= 20 s",
         yes[t.get("time_to_target_met", False)]),
        ("peers' time to the target over ours (legs 1 & 6, 3 seeds)", "; ".join(
            f"{n}: median {p['median']:.2f} [{p['min']:.2f}, {p['max']:.2f}]" for n, p in peer.items() if p), "-", "-"),
        (f"equal quality (legs 1 & 6, seed 0; `{json.dumps(eq['config'])}`): the paper DE's F and the target",
         f"F {eq['fitness']:.2f} against "
         f"{eq['paper_fitness']:.2f} after {eq['wall_s']:.1f} s: {'reached' if eq['reached'] else 'not reached'}",
         "<= 60 s", yes[t.get("equal_quality_met", False)]),
        ("the bench itself", f"{f['bench_wall_s']:.0f} s", "< 240 s", yes[t.get("bench_met", False)]),
    ]
    host = machine_text(row["machine"]) if "machine" in row else f"{row['cores']} cores (the CPU not recorded)"
    out = [f"`gaitmend bench --kind recovery --json` on {host}, at load {row['load_before']:.1f} before and "
           f"{row['load_after']:.1f} after (the bench's own two threads count in the load):", "",
           "| figure | measured | issue 22's target | |", "|---|---|---|---|"]
    return out + [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in cells] + [""]


def speed_markdown(rows: list[dict], docs: Path = Path("docs")) -> str:
    """The page's generated text from the runs and Table II's rows under ``docs``."""
    return render_markdown(rows, _table2_rows(docs))


def render(datas: list) -> str:
    """docs/recovery_speed.md's generated section, from docs/recovery_speed.json and docs/table2.json."""
    rows, table2 = datas
    if rows is None:
        return missing(JSON, COMMAND)
    return render_markdown(rows, table2 or [])


def page(md: str) -> str:
    """The page the command writes: its title, then ``md`` inside the generated-section marker,
    so `gaitmend docs` and the docs-from-data test re-render it from the JSON."""
    return f"{TITLE}\n\n{marked(SECTION, COMMAND, md)}\n"


def render_markdown(rows: list[dict], table2: list[dict]) -> str:
    """Everything below the title, from the runs (docs/recovery_speed.json) and Table II's rows
    (docs/table2.json, the paper DE's F where this page has no run of it): nothing is measured here."""
    rows = by_config(rows)
    runs = [r for r in rows if r["part"] in ("paper", "fast", "equal") or r["part"].startswith("alt_")]
    out = [INTRO]
    benches = [r for r in rows if r["part"] == "bench"]
    if benches:
        out += ["## The issue's targets", "", "Every run of the bench, oldest first (the equal-quality configuration "
                "is the one of its time). Runs differ by the machine's load and by the host: sessions run on hosts "
                "sold under one CPU name but of different speed, so each run's raw rollout steps/s (its first row: "
                "the same workload every time) says how fast its host was; the runs before the CPU's family and "
                "model were recorded name only their cores.", ""]
        for bench in benches:
            out += bench_markdown(bench)
    out += ["## Changes and their gains", ""] + gains_markdown(rows, table2)
    scaling = [r for r in rows if r["part"] == "scaling"]
    if scaling:
        paper = [r["sim_steps"] + r["cut_steps_saved"] for r in rows if r["part"] == "paper"]
        out += scaling_markdown(scaling[-1], statistics.median(paper) if paper else None,
                                benches[-1]["figures"]["paper_recovery_wall_s"] if benches else None)
    out += ["## Equal quality and time to the target", "",
            "Paper DE F: the runs below, else docs/table2.json's full-walk run for that seed. Steps count every walk "
            "the search simulated (a cut walk's steps up to its cut); the paper DE's include the steps its cut walks "
            "saved, so they are the full-walk search's. Wall times are of the hosts the runs ran on, which differ in "
            "speed (the runs' table at the end names the host where the run recorded it).", ""] + summary_markdown(
                runs, table2) + paired_markdown(runs, table2)
    out += [RULE]
    for part, render in (("cap", cap_markdown), ("check", check_markdown), ("control", control_markdown)):
        got = [r for r in rows if r["part"] == part]
        if got:
            out += render(got)
    out += short_markdown(rows, table2) + perturbed_markdown(rows)
    out += ["## Tried and rejected", ""]
    prof = next((r for r in rows if r["part"] == "profile"), None)
    if prof is not None:
        out += profile_markdown(prof)
    var = [r for r in rows if r["part"] == "variants"]
    if var:
        out += variants_markdown(var)
    coarse = [r for r in rows if r["part"] == "coarse"]
    if coarse:
        out += coarse_markdown(coarse)
    if any(r["part"].startswith("alt_") for r in rows):
        out += alternatives_markdown(rows, table2)
    out += ["## Every search run", ""] + runs_markdown(runs)
    return "\n".join(out)

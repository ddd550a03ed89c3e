"""How long a paper-size recovery job takes, and the scale of its F, from Table II's rows
(issue 28: every published number from committed data). Each row of docs/table2.json is
a whole job (DE 30 x 60, the random-search control at the same budget, the robustness
re-runs) with its ``wall_s``; rows written since the runner recorded it also carry the
machine's 1-minute load before and after the run (``load_before``, ``load_after``) and
its ``cores``. The renderers state every time with that load, or say it was not recorded,
so a time measured on a loaded machine is never read as an idle machine's."""

from __future__ import annotations

import statistics

from app.core.host import machine_text
from app.jobs.recovery.reproduce.page_prose import loss
from app.jobs.recovery.spec import RecoverySpec


def paper_rows(rows: list[dict] | None, version: int) -> list[dict]:
    """The rows of the current format at the default spec's budget (every timestep)."""
    s = RecoverySpec().search
    return [r for r in rows or [] if r.get("version") == version and r.get("generations") == s.generations
            and r.get("population") == s.population]


def _seeds(rows: list[dict]) -> str:
    seeds = sorted({r["seed"] for r in rows})
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"seeds {seeds[0]}-{seeds[-1]}"
    return ("seed " if len(seeds) == 1 else "seeds ") + ", ".join(str(s) for s in seeds)


def load_text(rows: list[dict], word: str = "load ") -> str:
    """The 1-minute load the rows ran at ('load 4.1-7.3', 'load not recorded', or both)."""
    loads = [x for r in rows for x in (r.get("load_before"), r.get("load_after")) if x is not None]
    bare = sum(1 for r in rows if r.get("load_before") is None)
    parts = ([f"{word}{min(loads):.1f}-{max(loads):.1f}"] if loads else []) + (
        [f"{word}not recorded" if bare == len(rows) else f"{word}not recorded for {bare}"] if bare else [])
    return "; ".join(parts)


def spread(rows: list[dict], unit: float = 1.0, fmt: str = ".0f") -> tuple[str, str, str]:
    """(median, fastest, slowest) of the rows' wall_s, divided by ``unit``, as text."""
    walls = [r["wall_s"] / unit for r in rows]
    return tuple(format(v, fmt) for v in (statistics.median(walls), min(walls), max(walls)))


def _ms(step: float) -> str:
    return f"{1000 * step:g} ms"


def render_job_time(datas: list, version: int) -> str:
    """docs/recovery.md's 'what it costs': Table II's wall times by step, the default job's
    damage and all of Table II's damages, with the runs' seeds and load."""
    rows = paper_rows(datas[0], version)
    if not rows:
        return "*No paper-budget row in docs/table2.json yet (`gaitmend reproduce recovery --write-docs`).*"
    default = list(RecoverySpec().damage.lost_legs)
    out = ["| step | damage | runs | median (s) | fastest / slowest (s) | 1-minute load |", "|---|---|---|---|---|---|"]
    for step in sorted({r["timestep_s"] for r in rows}):
        at = [r for r in rows if r["timestep_s"] == step]
        for name, group in ((f"{loss(default)} (the default job)", [r for r in at if r["lost_legs"] == default]),
                            (f"all {len({tuple(r['lost_legs']) for r in at})} Table II damages", at)):
            if group:
                med, lo, hi = spread(group)
                out.append(f"| {_ms(step)} | {name} | {len(group)} ({_seeds(group)}) | {med} | {lo} / {hi} | "
                           f"{load_text(group, '')} |")
    return "\n".join(out)


FIRST_KEY = "first-command"  # docs/readme_examples.json's run of the README's first command (app/cli/examples.py)


def _measured_first(examples: dict | None) -> str:
    """The README's first command's job as `gaitmend reproduce readme-examples` timed it (its
    latest run), with the load; then the latest run on each other host that recorded its CPU
    family and model (hosts sold under one CPU name differ in speed, so one host's time is
    not a user's); empty when it was not timed."""
    runs = [r for r in (examples or {}).get("runs", []) if r.get("key") == FIRST_KEY]
    if not runs:
        return ""
    r = runs[-1]
    latest: dict[str, dict] = {}  # host -> its latest run, newest first
    for o in reversed(runs[:-1]):
        m = o.get("machine", {})
        if "cpu_family" in m and "cpu_model" in m and machine_text(m) != machine_text(r["machine"]):
            latest.setdefault(machine_text(m), o)
    others = "".join(f"; {o['wall_s'] / 60:.1f} min on {host} (load {o['load_before']:.1f} before and "
                     f"{o['load_after']:.1f} after, {o['date']})" for host, o in latest.items())
    return (f"{r['wall_s'] / 60:.1f} min as the README writes it ({machine_text(r['machine'])}, 1-minute load "
            f"{r['load_before']:.1f} before and {r['load_after']:.1f} after, {r['date']}; "
            f"[docs/benchmarks.md](docs/benchmarks.md#whole-jobs)){others}. ")


def render_readme_time(datas: list, version: int) -> str:
    """README.md's line under the first command: that job timed as written (docs/readme_examples.json,
    when measured), and Table II's runs of the same job (the default spec), with their load."""
    spec = RecoverySpec()
    rows = [r for r in paper_rows(datas[0], version) if r["lost_legs"] == list(spec.damage.lost_legs)
            and r["timestep_s"] == spec.sim.timestep_s]
    measured = _measured_first(datas[1] if len(datas) > 1 else None)
    if not rows:
        return f"How long the first command takes: {measured or 'no run of it in docs/table2.json yet.'}".rstrip()
    med, lo, hi = spread(rows, 60.0, ".1f")
    cores = sorted({r["cores"] for r in rows if r.get("cores")})
    machine = f" ({'/'.join(str(c) for c in cores)} cores)" if cores else ""
    return (f"How long the first command takes: {measured}{'The' if measured else 'the'} same job is Table II's {loss(spec.damage.lost_legs)} "
            f"row at {_ms(spec.sim.timestep_s)} ([docs/table2.json](docs/table2.json)): its {len(rows)} runs "
            f"({_seeds(rows)}) took a median of {med} min ({lo} to {hi} min) on the project's machine{machine}, "
            f"shared with other work ({load_text(rows)}).")


def render_f_scale(datas: list, version: int) -> str:
    """docs/recovery.md's 'what F is': the forward distance, the roll and pitch amplitudes and
    the F of Table II's answers at the default step, one-leg and two-leg losses apart."""
    dt = RecoverySpec().sim.timestep_s
    rows = [r for r in paper_rows(datas[0], version) if r["timestep_s"] == dt]
    if not rows:
        return "*No paper-budget row at the default step in docs/table2.json yet.*"
    out = []
    for n in sorted({len(r["lost_legs"]) for r in rows}):
        g = [r for r in rows if len(r["lost_legs"]) == n]
        fwd = [100 * r["best"]["y_f_m"] for r in g]
        amp = [max(r["best"]["roll_amp_deg"], r["best"]["pitch_amp_deg"]) for r in g]
        f = [r["best_fitness"] for r in g]
        legs = ("one leg", "two legs")[n - 1] if n < 3 else f"{n} legs"
        which = ", ".join(sorted({loss(r["lost_legs"]) for r in g}))
        out.append(f"- {legs} lost ({len(g)} answer{'s' if len(g) != 1 else ''}, {which}): forward "
                   f"{min(fwd):.0f}-{max(fwd):.0f} cm, the larger of roll and pitch amplitude "
                   f"{min(amp):.1f}-{max(amp):.1f} deg, F {min(f):.1f}-{max(f):.1f}.")
    return (f"Table II's answers at {_ms(dt)} (every seed in `docs/table2.json`, the paper's budget):\n"
            + "\n".join(out))


def estimate(rows: list[dict], version: int, runs: int, scale: float) -> str:
    """The time estimate `gaitmend reproduce recovery` prints: ``runs`` runs at ``scale`` x
    the paper budget's cost, from the fastest and the median of the rows at the default
    step (with their load), or a note that there is none to go by."""
    dt = RecoverySpec().sim.timestep_s
    done = [r for r in paper_rows(rows, version) if r["timestep_s"] == dt]
    if not done:
        return "no estimate (no paper-budget run at this step to go by)"
    walls = [r["wall_s"] for r in done]
    return (f"estimate {runs * min(walls) * scale / 60:.0f}-{runs * statistics.median(walls) * scale / 60:.0f} min "
            f"(the fastest and the median of the {len(done)} runs done, {load_text(done)})")

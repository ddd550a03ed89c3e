"""`gaitmend bench`: every registered kind's benchmark entries, measured in one go
(performance targets live in the kinds' entries, never in timed unit tests); and
`gaitmend reproduce bench`, which runs it kind by kind and keeps each kind's figures, with
the machine and its load, in docs/benchmarks.json (app/results/benchmarks.py renders them).

The reproduction lives here, not in a kind's experiments: it spans every kind and measures
with the very function `gaitmend bench --kind K --json` calls (``run_bench``). ``--kinds
studies`` measures, with the function `gaitmend bench --studies --json` calls
(app/cli/study_bench.py ``study_bench``), a study's dispatch overhead per point on the
deployment the GAITMEND_* variables name, and records that deployment."""

from __future__ import annotations

import datetime as _dt
import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from app.cli.study_bench import POINTS, study_bench
from app.core.host import machine
from app.jobs.base import Experiment
from app.jobs.ledger import ROOT, write_json_atomic
from app.jobs.registry import KINDS
from app.results import benchmarks
from app.results.provenance import git_commit


def run_bench(quick: bool = False, log: Callable[[str], None] = print, kinds: list[str] | None = None) -> dict:
    figures: dict = {"cores": os.cpu_count(), "quick": quick}
    for name, kind in KINDS.items():
        if kinds is not None and name not in kinds:
            continue
        for entry in kind.bench():
            log(f"{entry.name}: {entry.help} ...")
            figures[entry.name] = entry.run(quick, log)
    if kinds is None:  # every figure: adaptation is no kind, its bench is gathered here (app/cli/adapt_bench.py)
        from app.cli.adapt_bench import adapt_bench

        figures |= adapt_bench(quick, log)
    return figures


# -- gaitmend reproduce bench -------------------------------------------------------------------

STUDIES = benchmarks.STUDIES  # --kinds' name for `gaitmend bench --studies`, beside the kinds
ADAPT = benchmarks.ADAPT  # --kinds' name for `gaitmend bench --adapt` (an adaptation session is no kind)


class BenchParams(BaseModel):
    model_config = ConfigDict(extra="forbid")

    kinds: str = Field("", description="kinds to measure, comma-separated, even those the file holds already (a new "
                                       "run is appended beside the old); empty: every kind with a bench the file "
                                       f"does not hold yet. '{STUDIES}': a study's dispatch overhead per point "
                                       "(`gaitmend bench --studies --json`) on the deployment the GAITMEND_* "
                                       f"variables name, only when named; '{ADAPT}': an adaptation session's "
                                       "proposal time (`gaitmend bench --adapt --json`), only when named")
    study_points: int = Field(POINTS, ge=1, le=10000, description=f"the points of --kinds {STUDIES}' study ({POINTS}: the "
                                                        "published size; fewer only for a smoke test)")
    json_out: Path = Field(Path(benchmarks.JSON), description="the file each kind's run is appended to")

    @field_validator("kinds")
    @classmethod
    def _known(cls, v: str) -> str:
        unknown = [k for k in _names(v) if k not in (STUDIES, ADAPT) and (k not in KINDS or not KINDS[k].bench())]
        if unknown:
            raise ValueError(f"no kind with a bench named {', '.join(unknown)} (kinds: {', '.join(KINDS)}; "
                             f"or {STUDIES}: a study's dispatch overhead; or {ADAPT}: an adaptation's proposal time)")
        return v

    @field_validator("study_points")
    @classmethod
    def _points_need_studies(cls, v: int, info: ValidationInfo) -> int:
        if v != POINTS and STUDIES not in _names(info.data.get("kinds", "")):
            raise ValueError(f"{v} points: only --kinds {STUDIES} runs a study (the kinds' benches have no points)")
        return v


def _names(text: str) -> list[str]:
    return [k.strip() for k in text.split(",") if k.strip()]


def measured(work: Callable[[], dict]) -> dict:
    """``work()``'s figures with where and when they were measured: the machine, the 1-minute
    load average before and after, the niceness, the commit as the work starts (the code it
    ran; others may commit while it runs), the UTC date as it finishes and its wall seconds."""
    commit, before, t0 = git_commit(ROOT), os.getloadavg()[0], time.perf_counter()
    out = work()
    wall, after = time.perf_counter() - t0, os.getloadavg()[0]
    return out | {"machine": machine(), "load_before": before, "load_after": after, "nice": os.nice(0),
                  "commit": commit, "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                  "wall_s": round(wall, 1)}


def _timed(kind: str, work: Callable[[], dict]) -> dict:
    """A row of ``kind``: ``work()``'s figures, with where and when (``measured``) and this
    process's CPU seconds."""
    c0 = time.process_time()
    return measured(lambda: {"kind": kind} | work()) | {"cpu_s": round(time.process_time() - c0, 1)}


def measure_kind(kind: str, log: Callable[[str], None], bench: Callable[..., dict] = run_bench) -> dict:
    """One kind's `gaitmend bench --kind K --json`, in this process."""
    def figures() -> dict:
        out = bench(quick=False, log=log, kinds=[kind])
        return {"figures": {k: v for k, v in out.items() if k not in ("cores", "quick")}}

    return _timed(kind, figures)


def measure_studies(points: int, log: Callable[[str], None], bench: Callable[..., dict] = study_bench) -> dict:
    """`gaitmend bench --studies --json` at ``points`` points, in this process (the API; the
    worker is its own process, whose CPU seconds are not counted), with its deployment."""
    def figures() -> dict:
        out = bench(points, log)
        return {"deployment": out["deployment"], "figures": {"study_dispatch": out["study_dispatch"]}}

    return _timed(STUDIES, figures)


def append_measured(path: Path, experiment: str, command: str, todo: list, measure: Callable[[Any], dict],
                    label: Callable[[Any], str], log: Callable[[str], None]) -> dict:
    """The measurement file at ``path`` (a new one named by ``experiment`` and ``command``),
    with each item of ``todo`` measured one at a time and appended, the file rewritten as each
    ends (an interruption loses only the measurement under way)."""
    data = (json.loads(path.read_text()) if path.exists()
            else {"schema": 1, "experiment": experiment, "command": command, "runs": []})
    for item in todo:
        log(f"{label(item)} (load {os.getloadavg()[0]:.1f}) ...")
        data["runs"].append(measure(item))
        write_json_atomic(path, data)
        log(f"{label(item)}: {data['runs'][-1]['wall_s']:.0f} s, appended to {path}")
    return data


def measure_adapt(log: Callable[[str], None]) -> dict:
    """`gaitmend bench --adapt --json` (the published size), in this process."""
    from app.cli.adapt_bench import adapt_bench

    return _timed(ADAPT, lambda: {"figures": adapt_bench(False, log)})


def reproduce_bench(p: BenchParams, log: Callable[[str], None] = print, bench: Callable[..., dict] = run_bench,
                    studies: Callable[..., dict] = study_bench) -> str:
    """Each kind asked for (or each not yet in the file), one at a time, appended as it ends;
    the study dispatch bench when --kinds names it."""
    have = {r["kind"] for r in json.loads(p.json_out.read_text())["runs"]} if p.json_out.exists() else set()
    todo = _names(p.kinds) or [k for k, kind in KINDS.items() if kind.bench() and k not in have]

    def measure(k: str) -> dict:
        if k == ADAPT:
            return measure_adapt(log)
        return measure_studies(p.study_points, log, studies) if k == STUDIES else measure_kind(k, log, bench)

    def label(k: str) -> str:
        if k == ADAPT:
            return f"{k}: gaitmend bench --adapt --json"
        return (f"{k}: gaitmend bench --studies --json ({p.study_points} points)" if k == STUDIES
                else f"{k}: gaitmend bench --kind {k} --json")

    data = append_measured(p.json_out, "bench", benchmarks.COMMAND, todo, measure, label, log)
    if not todo:
        log(f"every kind is in {p.json_out} already (--kinds K re-measures one)")
    shown = [benchmarks.render_all(data)] if set(todo) - {STUDIES, ADAPT} or not todo else []
    return "\n".join(shown + ([benchmarks.render_studies(data)] if STUDIES in todo else [])
                     + ([benchmarks.render_adapt(data)] if ADAPT in todo else []))


EXPERIMENT = Experiment("bench", "every kind's `gaitmend bench --kind K --json`, one kind at a time, each appended "
                                 "with the machine, its load before and after, the commit and the date (kinds "
                                 "already in --json-out are skipped unless --kinds names them); --kinds studies: "
                                 "`gaitmend bench --studies --json` on the deployment the GAITMEND_* variables "
                                 "name, recorded with it; --kinds adapt: `gaitmend bench --adapt --json`",
                        BenchParams, reproduce_bench, benchmarks.sections())

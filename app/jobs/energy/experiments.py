"""Paper 003 reproduced: ``gaitmend reproduce energy`` (the default trot search with every
control and robustness case), ``energy-table1`` (the paper's own Table 1 trot, no search)
and ``energy-knots`` (how the answer moves with the time grid). The bench figures: one
fitness evaluation on one core, and the default GA on two worker processes."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.base import BenchEntry, Experiment, MemoryContext, dumps


def _md_table(columns, rows) -> str:
    head = "| " + " | ".join(columns) + " |\n|" + "---|" * len(columns) + "\n"
    return head + "\n".join("| " + " | ".join(str(c) for c in r) + " |" for r in rows) + "\n"


def report(summary: dict, wall_s: float, spec_json: str) -> str:
    """The docs/energy.md tables of one run, from its summary (all measured)."""
    from app.jobs.energy import present

    out = [f"Spec: `{spec_json}`  \nWall time: {wall_s:.0f} s; evaluations: {summary['timing']['evaluations']}\n"]
    for t in present.summary_tables(summary):
        out.append(f"**{t['title']}**\n\n" + _md_table(t["columns"], t["rows"]) + "".join(f"\n{n}  " for n in t["notes"]))
    a = summary.get("analysis", {}).get("srb_vs_legs")
    if a:
        rows = []
        for name, m in (("SRB, massless legs, on a massless-legged robot", a["srb_on_massless_legs"]),
                        ("SRB solution re-evaluated on the heavy legs", a["srb_on_heavy_legs"]),
                        ("SRB + dummy legs (this kind)", a["leg_dynamics"])):
            rows.append([name, *(f"{m[k]:.4g}" if isinstance(m.get(k), float) else str(m.get(k, "-"))
                                 for k in ("cot_nlp_first", "cot_final", "eps_nlp_N", "eps_qp_N", "periodicity_error",
                                           "feasible"))])
        out.append("**SRB only vs leg dynamics (same gait and links)**\n\n"
                   + _md_table(["model", "CoT NLP", "CoT final", "eps_NLP (N)", "eps_QP (N)", "w", "feasible"], rows))
    return "\n\n".join(out)


class TrotParams(BaseModel):
    population: int = Field(40, ge=4, le=200, description="GA population (even)")
    generations: int = Field(40, ge=1, le=500, description="GA generations after the initial population")
    seed: int = Field(0, ge=0, description="seed of the GA and the random search")
    workers: int = Field(0, ge=0, le=64, description="processes per population (0 = every core)")
    out: str = Field("", description="write the markdown and the summary JSON here (folder); empty: print only")


def _run_spec(data: dict, log: Callable[[str], None]) -> tuple[dict, float, str]:
    from app.jobs.energy.run import run
    from app.jobs.energy.spec import EnergySpec

    spec = EnergySpec.parse(data)

    class Ctx(MemoryContext):
        def progress(self, done, total, info):
            if info.get("phase") in ("ga", "random_search") and info.get("generation", 0) % 5 == 0:
                log(f"  {info['phase']} generation {info['generation']}: best J {info['best_J']:.4g} ({done}/{total})")

    t = time.perf_counter()
    r = run(spec, Ctx())
    return json.loads(dumps(r.summary)), time.perf_counter() - t, json.dumps(spec.model_dump(mode="json"))


def _write(out: str, name: str, md: str, summary: dict) -> None:
    if out:
        p = Path(out)
        p.mkdir(parents=True, exist_ok=True)
        (p / f"{name}.md").write_text(md)
        (p / f"{name}.json").write_text(json.dumps(summary, indent=1))


def _reproduce(data: dict, out: str, name: str, log: Callable[[str], None]) -> str:
    """Run one spec, and return (and write under ``out``, as ``name``) its docs tables."""
    summary, wall, spec_json = _run_spec(data, log)
    md = report(summary, wall, spec_json)
    _write(out, name, md, summary)
    return md


def _trot(params: TrotParams, log: Callable[[str], None]) -> str:
    data = {"kind": "energy", "search": {"population": params.population, "generations": params.generations,
                                         "seed": params.seed, "workers": params.workers}}
    log(f"energy: GA {params.population} x ({params.generations} + 1) on the trot, with controls and robustness ...")
    return _reproduce(data, params.out, "energy_trot", log)


class Table1Params(BaseModel):
    out: str = Field("", description="folder for the markdown and JSON; empty: print only")
    swing_height_m: float = Field(0.25, ge=0.02, le=0.4, description="z_sp (Table 1: 0.25 m)")


def _table1(params: Table1Params, log: Callable[[str], None]) -> str:
    data = {"kind": "energy", "search": {"optimizer": "none"}, "task": {"swing_height_m": params.swing_height_m},
            "evidence": {"random_search": False}}
    log("energy: Table 1's trot (T = 0.46 s, Table 1 links), no search ...")
    return _reproduce(data, params.out, "energy_table1", log)


class KnotsParams(BaseModel):
    knots: str = Field("96,192,384", description="comma-separated knot counts per period (even)")


def _knots(params: KnotsParams, log: Callable[[str], None]) -> str:
    from app.jobs.energy.dynamics.gait import Task, trot
    from app.jobs.energy.dynamics.pipeline import EvalConfig, evaluate
    from app.robots.quadruped import QUADRUPED25

    rows = []
    for K in (int(k) for k in params.knots.split(",")):
        r = evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig(knots=K), detail=True)
        rows.append([K, f"{r['cot']['nlp']:.4f}", f"{r['cot']['qp']:.4f}", f"{r['cot']['final']:.4f}",
                     f"{r['eps']['nlp']['norm']:.3f}", f"{r['eps']['qp']['norm']:.4f}", f"{r['periodicity_error']:.3f}",
                     f"{r['nlp_forward_periodicity_error']:.3f}", f"{r['seconds']:.2f}"])
        log(f"  {K} knots done")
    return _md_table(["knots", "CoT NLP", "CoT QP", "CoT final", "eps_NLP (N)", "eps_QP (N)", "w (QP forces)",
                      "w (NLP forces)", "eval (s)"], rows)


EXPERIMENTS = [
    Experiment("trot", "paper 003's trot: GA over T and links (Table 1 defaults), controls and robustness; "
               "writes the docs/energy.md tables", TrotParams, _trot),
    Experiment("table1", "the paper's own Table 1 trot evaluated through every stage and in MuJoCo physics",
               Table1Params, _table1),
    Experiment("knots", "the Table 1 trot at several time grids (convergence of the answer)", KnotsParams, _knots),
]


def bench_energy(quick: bool = False, log: Callable[[str], None] = print) -> dict:
    """(a) one fitness evaluation (IK + inverse dynamics + NLP + QP + forward check) on one
    core, median of several (target <= 0.5 s); (b) the default GA (40 x (40 + 1)) on two
    worker processes, without the controls (target <= 300 s; quick: 8 x (2 + 1))."""
    from app.jobs.energy.dynamics.gait import Task, trot
    from app.jobs.energy.dynamics.pipeline import EvalConfig, evaluate
    from app.jobs.energy.run import run
    from app.jobs.energy.spec import EnergySpec
    from app.robots.quadruped import QUADRUPED25

    log("(a) one fitness evaluation, Table 1 trot, one core ...")
    evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig())  # imports, caches
    times, cpu, parts = [], [], []
    for _ in range(3 if quick else 10):
        c0 = time.process_time()
        r = evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig())
        cpu.append(time.process_time() - c0)  # on a shared machine wall time also counts the others' work
        times.append(r["seconds"])
        parts.append(r["timings_s"])
    fig = {"fitness_eval_s": float(np.median(times)), "fitness_eval_cpu_s": float(np.median(cpu)),
           "fitness_eval_parts_s": {k: float(np.median([p[k] for p in parts])) for k in parts[0]}}
    pop, gens = (8, 2) if quick else (40, 40)
    log(f"(b) GA {pop} x ({gens} + 1) on two worker processes ...")
    spec = EnergySpec.parse({"kind": "energy", "search": {"population": pop, "generations": gens, "workers": 2},
                             "physics": {"periods": 1}, "evidence": {"controls": False, "random_search": False,
                                                                     "robustness": False}})
    t, c0 = time.perf_counter(), time.process_time()
    s = run(spec, MemoryContext()).summary
    fig["ga_wall_s"] = time.perf_counter() - t
    fig["ga_parent_cpu_s"] = time.process_time() - c0  # the workers' CPU is not in it
    fig["ga_evaluations"] = s["search"]["evaluations"]
    fig["ga_best_J"] = s["J"]
    if not quick:
        fig["targets"] = {"fitness_eval_s_max": 0.5, "ga_wall_s_max": 300.0,
                          "fitness_eval_met": fig["fitness_eval_s"] <= 0.5, "ga_met": fig["ga_wall_s"] <= 300.0}
    return fig


BENCH = [BenchEntry("energy", "one fitness evaluation (one core) and the default GA (two processes)", bench_energy)]

"""Issue 43's evidence, reproduced: ``gaitmend reproduce repertoire`` (MAP-Elites against a
uniform random search at equal budget, per robot and seed, with the archive's convergence,
the wall time, the timestep check and the elites re-simulated on held-out models) and
``gaitmend reproduce repertoire-emitter`` (the small paired experiment that chose the
default emitter's step).

Both are resumable ledgers (app/jobs/ledger.py): each finished run is appended to the JSON
under docs/ the moment it ends, a re-run skips the runs already there, so a reproduction
killed between runs (or cut off by the end of a session) continues where it stopped. A run
killed midway resumes from its own checkpoint (the job's, bit-identical; kept under
``--checkpoints``, outside docs/) rather than from its start.

Robots: the built-in hexapod, and two robots nobody here wrote, uploaded as a user uploads
them (app/robots/upload ``prepare``: the sanitised model, its assets and its detected leg
map) from the wheels the test extra installs: dm_control's suite quadruped and Gymnasium's
Ant. An uploaded robot's id is the first 32 hex digits of its content hash, so a run's key
changes with the model.

The ledgers' code version hashes the kind's science modules (``SCIENCE``), not the shared
robot layer other work edits; each run records the sha256 of the model it simulated
(``model_sha256``) instead, so a run of another model is visible in the file."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field, field_validator

from app.jobs import stats
from app.jobs.base import Experiment
from app.jobs.ledger import Ledger, current_runs, run_key
from app.jobs.reporting import Section, md_table, missing, num, progress_note
from app.jobs.repertoire.reproduce.runs import ROBOT_NAMES, emitter_job, robot_of, run_one, timestep_job

SCIENCE = ("app/jobs/repertoire/spec.py", "app/jobs/repertoire/evaluate.py", "app/jobs/repertoire/run.py",
           "app/jobs/repertoire/body.py", "app/jobs/repertoire/controller.py", "app/jobs/repertoire/archive.py",
           "app/jobs/repertoire/reproduce/runs.py", "app/sim/batch.py", "app/sim/perturb.py")
# the emitter runs state every setting they depend on (emitter_spec), so the spec's defaults are not hashed
EMITTER_SCIENCE = SCIENCE[1:]
EVIDENCE_JSON, EMITTER_JSON = "docs/repertoire_evidence.json", "docs/repertoire_emitter.json"
EVIDENCE_COMMAND = "gaitmend reproduce repertoire --write-docs"
EMITTER_COMMAND = "gaitmend reproduce repertoire-emitter --write-docs"
TIMESTEP_JSON, TIMESTEP_COMMAND = "docs/repertoire_timestep.json", "gaitmend reproduce repertoire-timestep --write-docs"
# The map's convergence rule (recovery's, docs/recovery.md, asks every answer to move < 5 %; a map's best
# elites include gaits on the edge of falling, so the rule is on their median and on the map's content,
# the cells): halving the step moves the best elites' median forward distance by < MEDIAN_REL and keeps at
# least SAME_CELL of them in their cell, on every seed.
MEDIAN_REL, SAME_CELL = 0.05, 0.8
CHECKPOINTS = Path("reproduced/repertoire_checkpoints")


# -- gaitmend reproduce repertoire -----------------------------------------------------------------

def _default(section: str, name: str):
    from app.jobs.repertoire import spec as sp

    return getattr(sp, section).model_fields[name].default


class EvidenceParams(BaseModel):
    evaluations: int = Field(100_000, ge=2, le=10_000_000, description=(
        "MAP-Elites gaits per run (the random search gets as many): iterations = evaluations / batch size"))
    seeds: str = Field("0,1,2", description="seeds (comma-separated); each robot runs every seed")
    robots: str = Field("jethexa,dm_quadruped,gym_ant", description=f"robots (comma-separated) of {sorted(ROBOT_NAMES)}")
    batch_size: int = Field(0, ge=0, le=4096, description="gaits per iteration (0: the spec's default)")
    cells: int = Field(0, ge=0, le=100_000, description="archive cells (0: the spec's default)")
    duration_s: float = Field(0.0, ge=0.0, le=60.0, description="a trial's walking time (0: the spec's default)")
    timestep_s: float = Field(0.0, ge=0.0, le=0.01, description="the simulation step (0: the spec's default)")
    rescore_elites: int = Field(20, ge=0, le=10_000, description="best elites re-scored at half the step")
    held_out_elites: int = Field(20, ge=0, le=10_000, description="best elites re-simulated on the held-out models")
    history_points: int = Field(50, ge=2, le=10_000, description="convergence rows kept per run")
    json_out: Path | None = Field(Path(EVIDENCE_JSON), description=(
        "the ledger: each finished run is appended, a re-run skips the runs already there"))
    checkpoints: Path | None = Field(CHECKPOINTS, description="where a run in progress keeps its checkpoint")

    @field_validator("robots")
    @classmethod
    def _robots(cls, v: str) -> str:
        bad = [r for r in _split(v) if r not in ROBOT_NAMES]
        if bad or not _split(v):
            raise ValueError(f"unknown robots {bad}: choose from {sorted(ROBOT_NAMES)}")
        return v


def _split(v: str) -> list[str]:
    return [s.strip() for s in v.split(",") if s.strip()]


def evidence_spec(p: EvidenceParams, robot: str, seed: int) -> dict:
    """One run's job: the kind's defaults, but for the params' budget (and any override)."""
    batch = p.batch_size or _default("Search", "batch_size")
    data = {"kind": "repertoire", "robot": robot, "seed": seed,
            "search": {"iterations": max(1, p.evaluations // batch), "batch_size": batch,
                       "checkpoint_every": max(1, min(50, p.evaluations // batch // 20 or 1))},
            "evidence": {"random_control": True, "rescore_elites": p.rescore_elites}}
    if p.cells:
        data["archive"] = {"cells": p.cells}
    sim = {k: v for k, v in (("duration_s", p.duration_s), ("timestep_s", p.timestep_s)) if v}
    if sim:
        data["sim"] = sim
    return data


def _evidence(p: EvidenceParams, log: Callable[[str], None] = print) -> str:
    seeds, robots = [int(s) for s in _split(p.seeds)], _split(p.robots)
    led = Ledger(p.json_out, "repertoire-evidence", EVIDENCE_COMMAND, p.model_dump(mode="json"), SCIENCE,
                 planned=len(seeds) * len(robots))
    stores = {}
    for seed in seeds:  # seed-major: a cut-off reproduction has every robot at its first seeds
        for name in robots:
            if name not in stores:
                stores[name] = robot_of(name)
            rid, stored = stores[name]
            data = evidence_spec(p, rid, seed)
            ckpt = None
            if p.checkpoints is not None:
                ckpt = Path(p.checkpoints) / f"{run_key(data, seed, led.version)}.json"
            log(f"repertoire {name} seed {seed}: {data['search']['iterations']} x {data['search']['batch_size']} "
                "gaits, MAP-Elites and the random search")
            led.run(f"{name} seed {seed}", data, seed,
                    lambda data=data, name=name, stored=stored, ckpt=ckpt: run_one(
                        data, name, stored, ckpt, p.held_out_elites, p.history_points), log)
            if ckpt is not None:
                ckpt.unlink(missing_ok=True)
    return render_evidence([led.data])


def _runs(data: dict | None) -> list[dict]:
    return current_runs(data) if data else []


def _by_robot(runs: list[dict]) -> dict[tuple[str, int], list[dict]]:
    """The runs by (robot, MAP-Elites gaits per run): only runs of one budget are paired."""
    out: dict[tuple[str, int], list[dict]] = {}
    for r in runs:
        out.setdefault((r["result"]["robot"], r["result"]["budget"]["evaluations_per_arm"]), []).append(r)
    order = list(ROBOT_NAMES)

    def rank(key):
        return (order.index(key[0]) if key[0] in order else len(order), key[1])

    return {k: sorted(out[k], key=lambda r: r["seed"]) for k in sorted(out, key=rank)}


def _label(key: tuple[str, int], budget: bool = True) -> str:
    name = ROBOT_NAMES.get(key[0], key[0])
    return f"{name}, {key[1]:,} gaits per arm" if budget else name


def _partial(data: dict, runs: list[dict]) -> str:
    """'k of N planned runs' for the last invocation's budget, robots and seeds."""
    p = data.get("params") or {}
    robots, seeds = _split(p.get("robots", "")), [int(x) for x in _split(p.get("seeds", ""))]
    budget = p.get("evaluations", 0) // (p.get("batch_size") or _default("Search", "batch_size")) * (
        p.get("batch_size") or _default("Search", "batch_size"))
    done = sum(1 for r in runs if r["result"]["robot"] in robots and r["seed"] in seeds
               and r["result"]["budget"]["evaluations_per_arm"] == budget)
    planned = len(robots) * len(seeds)
    if done < planned:
        return (f"\n*Partial: {done} of {planned} planned runs at {budget:,} gaits per arm are in the data so far; "
                f"`{data['command']} --evaluations {p.get('evaluations')}` continues it (finished runs are skipped).*\n")
    return ""


def _fmt_int(v) -> str:
    return f"{v:,}" if v is not None else "-"


def _paired(rows: list[dict], metric: str, digits: int) -> str:
    a = [r["result"]["arms"]["map_elites"][metric] for r in rows]
    b = [r["result"]["arms"]["random"][metric] for r in rows]
    if any(v is None for v in a + b):
        return "-"
    if len(rows) < 2:
        return f"{a[0] - b[0]:+.{digits}f} (1 seed: no interval)"
    res = stats.paired(a, b, names=("MAP-Elites", "random search"))
    lo, hi = res["ci"] if res["ci"] else (None, None)
    ci = f" [{lo:+.{digits}f}, {hi:+.{digits}f}]" if lo is not None else ""
    return f"{res['mean_diff']:+.{digits}f}{ci}, {res['verdict']}"


def _mean(v: list) -> float | None:
    v = [x for x in v if x is not None]
    return float(np.mean(v)) if v else None


def _budgets(rows: list[dict]) -> str:
    b = sorted({r["result"]["budget"]["evaluations_per_arm"] for r in rows})
    return " / ".join(_fmt_int(x) for x in b)


def render_evidence(datas: list) -> str:
    data = datas[0]
    runs = _runs(data)
    if not runs:
        return missing(EVIDENCE_JSON, EVIDENCE_COMMAND)
    groups = _by_robot(runs)
    rows = []
    for name, rs in groups.items():
        arms = [r["result"]["arms"] for r in rs]
        b = rs[0]["result"]["budget"]
        rows.append([_label(name, False), ", ".join(str(r["seed"]) for r in rs), _budgets(rs),
                     f"{b['cells']:,}",
                     " / ".join(num(_mean([a[arm]["elites"] for a in arms]), "{:,.0f}") for arm in ("map_elites", "random")),
                     " / ".join(num(_mean([a[arm]["qd_score"] for a in arms]), "{:,.1f}") for arm in ("map_elites", "random")),
                     _paired(rs, "qd_score", 1),
                     " / ".join(num(_mean([a[arm]["best_forward_m"] for a in arms]), "{:.3f}")
                                for arm in ("map_elites", "random")),
                     _paired(rs, "best_forward_m", 3)])
    out = [md_table(["robot", "seeds", "gaits per arm", "cells", "cells filled (MAP-Elites / random, mean)",
                     "QD-score (MAP-Elites / random, mean)", "QD-score: paired difference [95 % CI]",
                     "best forward (m, MAP-Elites / random, mean)", "best forward: paired difference [95 % CI]"], rows)]
    out.append("\n" + stats.PAIRED_NOTE + " With 3 seeds the signed-rank test cannot reach p < 0.05 (its smallest "
               "p is 0.25), so no difference of 3 pairs is \"shown\" whatever its size; the intervals are the "
               "figures to read.\n")
    out.append(_timing_table(groups))
    out.append(_convergence_table(groups))
    out.append(_numerics_table(groups))
    out.append(_held_out_table(groups))
    out.append(_partial(data, runs))
    return "\n".join(out) + "\n"


def _timing_table(groups: dict[str, list[dict]]) -> str:
    rows = []
    for name, rs in groups.items():
        for r in rs:
            t, b = r["result"]["timing"], r["result"]["budget"]
            rate = t["evaluations_per_s"]
            rows.append([_label(name, False), r["seed"], _fmt_int(b["evaluations_per_arm"]),
                         _fmt_int(t["evaluations"]), f"{t['wall_s'] / 60:.1f}", f"{rate:.1f}",
                         f"{100_000 / rate / 60:.0f}", f"{t['threads']} threads, {t['cores']} cores, load "
                         f"{t['load_before']:.1f} / {t['load_after']:.1f}"
                         + (f", resumed at iteration {t['resumed_from_iteration']}"
                            if t.get("resumed_from_iteration") else "")])
    return ("\n**Wall time** (the job: MAP-Elites and the random search, one batch per iteration, plus the "
            "re-scorings; the machine is shared, so these are upper bounds; 100,000 MAP-Elites gaits is projected "
            "from the measured rate, not measured, unless the row's budget is 100,000):\n\n"
            + md_table(["robot", "seed", "gaits per arm", "gaits scored (both arms)", "wall (min)", "gaits/s",
                        "100,000 gaits would take (min)", "machine (1-min load before / after)"], rows))


def _convergence_table(groups: dict[str, list[dict]]) -> str:
    """Coverage and QD-score at a quarter, half and all of the budget (mean over seeds)."""
    rows = []
    for name, rs in groups.items():
        cells = []
        for frac in (0.25, 0.5, 1.0):
            cov, qd, rcov, rqd = [], [], [], []
            for r in rs:
                conv = r["result"]["convergence"]
                last = conv[-1]["evaluations"]
                row = min(conv, key=lambda c: abs(c["evaluations"] - frac * last))
                cov.append(row["coverage"])
                qd.append(row["qd_score"])
                rcov.append(row.get("random_coverage"))
                rqd.append(row.get("random_qd_score"))
            cells.append(f"{num(_mean(cov), '{:.1%}')} / {num(_mean(rcov), '{:.1%}')}; "
                         f"{num(_mean(qd), '{:,.1f}')} / {num(_mean(rqd), '{:,.1f}')}")
        rows.append([_label(name), *cells])
    return ("\n**Convergence** (coverage; QD-score, MAP-Elites / random, mean over the seeds, at a share of each "
            "run's budget; every run's curve, 50 points, is in the JSON's `convergence`):\n\n"
            + md_table(["robot", "after 1/4 of the gaits", "after 1/2", "after all"], rows))


def _numerics_table(groups: dict[str, list[dict]]) -> str:
    rows = []
    for name, rs in groups.items():
        meds, maxs, same, n, fell, rel = [], [], 0, 0, 0, []
        for r in rs:
            tc = r["result"]["timestep_check"]
            if not tc.get("elites"):
                continue
            meds.append(tc["abs_diff_m"]["median"])
            maxs.append(tc["abs_diff_m"]["max"])
            same += tc["same_cell"]
            n += tc["elites"]
            fell += tc["fell_at_half"]
            f0, f1 = np.asarray(tc["forward_m"]), np.asarray(tc["forward_half_m"])
            rel += (np.abs(f1 - f0) / np.maximum(np.abs(f0), 1e-9)).tolist()
        if not n:
            continue
        dt = rs[0]["result"]["timestep_check"]["timestep_s"]
        rows.append([_label(name), f"{dt * 1000:g} -> {dt * 500:g}", n,
                     f"{np.median(meds) * 100:.1f} / {max(maxs) * 100:.1f}", f"{np.median(rel):.1%}",
                     f"{np.mean(np.asarray(rel) < 0.05):.0%}", f"{same} of {n}", fell,
                     "passes" if np.median(rel) < MEDIAN_REL and same / n >= SAME_CELL else "fails"])
    if not rows:
        return ""
    return ("\n**Timestep check** (each run's best elites re-scored at half the step, the same model otherwise; "
            f"pooled over the seeds; the rule of \"Timestep\" above: median relative change < {MEDIAN_REL:.0%}, at "
            f"least {SAME_CELL:.0%} in their cell):\n\n"
            + md_table(["robot", "step (ms)", "elites", "forward change (cm, median of the runs' medians / largest)",
                        "median relative change", "within 5 %", "same cell", "fell at half",
                        "the map's rule (pooled)"], rows))


def _held_out_table(groups: dict[str, list[dict]]) -> str:
    rows = []
    for name, rs in groups.items():
        hos = [r["result"]["held_out"] for r in rs if r["result"]["held_out"]["elites"]]
        if not hos:
            continue
        n = sum(h["elites"] for h in hos)
        nominal = _mean([h["nominal_median_m"] for h in hos])
        cells = []
        for case in hos[0]["cases"]:
            cs = [next(c for c in h["cases"] if c["name"] == case["name"]) for h in hos]
            k = sum(c["keeps"] for c in cs)
            lo, hi = stats.wilson(k, n)
            cells.append(f"{num(_mean([c['median_forward_m'] for c in cs]), '{:.3f}')} m; keeps {k} of {n} "
                         f"({lo:.0%}-{hi:.0%}); fell {sum(c['fell'] for c in cs)}")
        rows.append([_label(name), n, num(nominal, "{:.3f}"), *cells])
    if not rows:
        return ""
    first = next(r["result"]["held_out"] for rs in groups.values() for r in rs if r["result"]["held_out"]["elites"])
    labels = [c["label"] for c in first["cases"]]
    return (f"\n**Held-out models** (each run's best elites re-simulated on models the map was not built on, the "
            f"project's named perturbations; per case: the elites' median forward distance (mean over the seeds), "
            f"how many keep their walk: upright and at least {first['keeps']:.0%} of their nominal distance, with a "
            f"95 % Wilson interval, and how many fell):\n\n"
            + md_table(["robot", "elites", "nominal median (m)", *labels], rows))


# -- gaitmend reproduce repertoire-emitter -----------------------------------------------------------

class EmitterParams(BaseModel):
    evaluations: int = Field(1000, ge=2, le=1_000_000, description="MAP-Elites gaits per run")
    seeds: str = Field("0,1,2", description="seeds (comma-separated)")
    iso_sigmas: str = Field("0.01,0.05,0.2", description="IsoLineDD's isotropic steps compared (comma-separated)")
    line_sigma: float = Field(0.2, ge=0.0, le=5.0, description="IsoLineDD's line step, the same in every arm")
    batch_size: int = Field(100, ge=1, le=4096, description="gaits per iteration")
    cells: int = Field(2000, ge=2, le=100_000, description="archive cells")
    timestep_s: float = Field(0.002, ge=0.0002, le=0.01, description="the simulation step")
    duration_s: float = Field(3.0, gt=0.0, le=60.0, description="a trial's walking time (s)")
    json_out: Path | None = Field(Path(EMITTER_JSON), description=(
        "the ledger: each finished run is appended, a re-run skips the runs already there"))


def emitter_spec(p: EmitterParams, sigma: float, seed: int, control: bool) -> dict:
    """Every setting the comparison depends on is stated, so a later change of the spec's
    defaults does not change these runs."""
    return {"kind": "repertoire", "robot": "jethexa", "seed": seed, "archive": {"cells": p.cells},
            "search": {"iterations": max(1, p.evaluations // p.batch_size), "batch_size": p.batch_size,
                       "emitter": "iso_line", "iso_sigma": sigma, "line_sigma": p.line_sigma,
                       "checkpoint_every": 1000},
            "sim": {"duration_s": p.duration_s, "settle_s": 0.5, "timestep_s": p.timestep_s},
            "evidence": {"random_control": control, "rescore_elites": 0}}


def _emitter(p: EmitterParams, log: Callable[[str], None] = print) -> str:
    seeds, sigmas = [int(s) for s in _split(p.seeds)], [float(s) for s in _split(p.iso_sigmas)]
    led = Ledger(p.json_out, "repertoire-emitter", EMITTER_COMMAND, p.model_dump(mode="json"), EMITTER_SCIENCE,
                 planned=len(seeds) * len(sigmas))
    for seed in seeds:
        for i, sigma in enumerate(sigmas):
            data = emitter_spec(p, sigma, seed, control=(i == 0))  # the random search is the same in every arm
            log(f"repertoire emitter: iso_sigma {sigma}, seed {seed}")
            led.run(f"iso_sigma {sigma} seed {seed}", data, seed, lambda data=data: emitter_job(data), log)
    return render_emitter([led.data])


def render_emitter(datas: list) -> str:
    data = datas[0]
    runs = _runs(data)
    if not runs:
        return missing(EMITTER_JSON, EMITTER_COMMAND)
    p = data["params"]
    arms: dict[str, dict[int, dict]] = {}
    for r in runs:
        sigma = r["spec"]["search"]["iso_sigma"]
        arms.setdefault(f"iso_sigma {sigma:g}", {})[r["seed"]] = r["result"]["map_elites"]
        if "random" in r["result"]:
            arms.setdefault("random search", {})[r["seed"]] = r["result"]["random"]
    rand = arms.get("random search", {})
    rows, means = [], {}
    for name, by_seed in sorted(arms.items(), key=lambda kv: kv[0] == "random search"):  # the control last
        seeds = sorted(by_seed)
        qd = [by_seed[s]["qd_score"] for s in seeds]
        means[name] = float(np.mean(qd))
        row = [name, ", ".join(map(str, seeds)), num(_mean([by_seed[s]["coverage"] for s in seeds]), "{:.1%}"),
               num(means[name], "{:,.1f}"), num(_mean([by_seed[s]["best_forward_m"] for s in seeds]), "{:.3f}")]
        common = [s for s in seeds if s in rand]
        if name != "random search" and len(common) >= 2:
            res = stats.paired([by_seed[s]["qd_score"] for s in common], [rand[s]["qd_score"] for s in common],
                               names=(name, "random search"))
            lo, hi = res["ci"] or (float("nan"), float("nan"))
            row.append(f"{res['mean_diff']:+,.1f} [{lo:+,.1f}, {hi:+,.1f}]")
        else:
            row.append("-")
        rows.append(row)
    searched = {k: v for k, v in means.items() if k != "random search"}
    best = max(searched, key=searched.get) if searched else None
    from app.jobs.repertoire.spec import Search

    default = f"iso_sigma {Search.model_fields['iso_sigma'].default:g}"
    text = (f"Hexapod (intact), {p['evaluations']:,} MAP-Elites gaits per run ({p['batch_size']} per iteration), "
            f"{p['cells']:,} cells, step {p['timestep_s'] * 1000:g} ms, line sigma {p['line_sigma']:g}; the random "
            f"search at the same budget into the same centroids (it draws the same gaits whatever the emitter, so it "
            f"ran once per seed).\n\n"
            + md_table(["arm", "seeds", "cells filled (mean)", "QD-score (mean)", "best forward (m, mean)",
                        "QD-score vs random: paired difference [95 % CI]"], rows)
            + f"\nHighest mean QD-score: **{best}**; the spec's default is {default}"
            + (" (the same)." if best == default else " (they differ: the default was not updated).")
            + f" The choice is on the QD-score (the map's quality, what a repertoire is for), not on the single best "
              f"walk, which the table shows too. Intervals: Student t, 95 %, over the {len(rand)} seeds' paired "
              f"differences; with fewer than 6 pairs the signed-rank test cannot reject, so by the project's rule "
              f"(app/jobs/stats.py) no difference here is \"shown\": the intervals are the "
              f"figures to read.\n")
    return text + progress_note(data, len(runs))


# -- gaitmend reproduce repertoire-timestep ---------------------------------------------------------

class TimestepParams(BaseModel):
    timesteps: str = Field("0.002,0.003,0.004", description="steps (s) checked (comma-separated)")
    seeds: str = Field("11,12,13", description="seeds (comma-separated)")
    evaluations: int = Field(1000, ge=2, le=1_000_000, description="MAP-Elites gaits per map")
    batch_size: int = Field(100, ge=1, le=4096, description="gaits per iteration")
    cells: int = Field(500, ge=2, le=100_000, description="archive cells")
    iso_sigma: float = Field(0.05, gt=0.0, le=1.0, description="IsoLineDD's isotropic step")
    elites: int = Field(50, ge=1, le=10_000, description="best elites re-scored at half the step")
    duration_s: float = Field(3.0, gt=0.0, le=60.0, description="a trial's walking time (s)")
    json_out: Path | None = Field(Path(TIMESTEP_JSON), description=(
        "the ledger: each finished run is appended, a re-run skips the runs already there"))


def timestep_spec(p: TimestepParams, dt: float, seed: int) -> dict:
    return {"kind": "repertoire", "robot": "jethexa", "seed": seed, "archive": {"cells": p.cells},
            "search": {"iterations": max(1, p.evaluations // p.batch_size), "batch_size": p.batch_size,
                       "emitter": "iso_line", "iso_sigma": p.iso_sigma, "line_sigma": 0.2, "checkpoint_every": 1000},
            "sim": {"duration_s": p.duration_s, "settle_s": 0.5, "timestep_s": dt},
            "evidence": {"random_control": False, "rescore_elites": p.elites}}


def _timestep(p: TimestepParams, log: Callable[[str], None] = print) -> str:
    seeds, dts = [int(s) for s in _split(p.seeds)], [float(s) for s in _split(p.timesteps)]
    led = Ledger(p.json_out, "repertoire-timestep", TIMESTEP_COMMAND, p.model_dump(mode="json"), EMITTER_SCIENCE,
                 planned=len(seeds) * len(dts))
    for dt in dts:
        for seed in seeds:
            data = timestep_spec(p, dt, seed)
            log(f"repertoire timestep {dt * 1000:g} ms, seed {seed}")
            led.run(f"{dt * 1000:g} ms seed {seed}", data, seed, lambda data=data: timestep_job(data), log)
    return render_timestep([led.data])


def render_timestep(datas: list) -> str:
    data = datas[0]
    runs = _runs(data)
    if not runs:
        return missing(TIMESTEP_JSON, TIMESTEP_COMMAND)
    p = data["params"]
    by_dt: dict[float, list[dict]] = {}
    for r in runs:
        by_dt.setdefault(r["result"]["timestep_s"], []).append(r)
    rows, passing = [], []
    for dt in sorted(by_dt):
        meds, cells, rates, ok = [], [], [], True
        for r in sorted(by_dt[dt], key=lambda r: r["seed"]):
            x = r["result"]
            f0, f1 = np.asarray(x["forward_m"]), np.asarray(x["forward_half_m"])
            med = float(np.median(np.abs(f1 - f0) / np.maximum(np.abs(f0), 1e-9)))
            share = x["same_cell"] / x["elites"]
            meds.append(f"{med:.1%}")
            cells.append(f"{x['same_cell']}/{x['elites']}")
            rates.append(x["evaluations"] / x["wall_s"])
            ok &= med < MEDIAN_REL and share >= SAME_CELL
        if ok:
            passing.append(dt)
        rows.append([f"{dt * 1000:g} -> {dt * 500:g}", ", ".join(str(r["seed"]) for r in by_dt[dt]), ", ".join(meds),
                     ", ".join(cells), f"{min(rates):.1f}-{max(rates):.1f}", "passes" if ok else "fails"])
    from app.jobs.repertoire.spec import TIMESTEP_S

    chosen = max(passing) if passing else None
    return (f"Hexapod (intact): per step and seed, a map of {p['evaluations']:,} MAP-Elites gaits ({p['cells']} cells, "
            f"iso sigma {p['iso_sigma']:g}, {p['duration_s']:g} s trials), then its {p['elites']} best elites "
            f"re-scored at half the step. The rule: median relative change of their forward distance < "
            f"{MEDIAN_REL:.0%} and at least {SAME_CELL:.0%} of them in the same cell, on every seed.\n\n"
            + md_table(["step (ms)", "seeds", "median relative change, per seed", "same cell, per seed",
                        "gaits/s (shared machine)", "rule"], rows)
            + f"\nLargest step that passes: **{num(chosen and chosen * 1000, '{:g}')} ms**; the spec's default is "
              f"{TIMESTEP_S * 1000:g} ms" + (" (the same)." if chosen == TIMESTEP_S else " (they differ).") + "\n"
            + progress_note(data, len(runs)))


def _others() -> list:
    """The kind's other reproductions, after these (a kind registers one list): the islands
    over workers (reproduce/islands.py) where that module exists."""
    try:
        from app.jobs.repertoire.reproduce.islands import EXPERIMENTS as islands
    except ModuleNotFoundError as e:
        if e.name != "app.jobs.repertoire.reproduce.islands":
            raise
        return []
    return list(islands)


EXPERIMENTS = [
    Experiment("evidence", "MAP-Elites against a random search at equal budget on the built-in hexapod and two "
               "uploaded robots (3 seeds), with convergence, wall time, the timestep check and held-out models; "
               "resumable (finished runs are skipped)", EvidenceParams, _evidence,
               sections=(Section("repertoire-evidence", (EVIDENCE_JSON,), render_evidence),)),
    Experiment("emitter", "the default emitter's isotropic step: a few settings against each other and a random "
               "search, paired by seed, at a small budget; resumable", EmitterParams, _emitter,
               sections=(Section("repertoire-emitter", (EMITTER_JSON,), render_emitter),)),
    Experiment("timestep", "the default step by the map's convergence rule: maps at several steps, their best elites "
               "re-scored at half the step; resumable", TimestepParams, _timestep,
               sections=(Section("repertoire-timestep", (TIMESTEP_JSON,), render_timestep),)),
    *_others(),
]

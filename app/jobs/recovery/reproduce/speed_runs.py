"""The searches and walks issue 22's speed page measures: each part's runs (the paper's DE,
the controls, the coarse step, the alternatives, the throughput), the answers re-walked
under the robustness cases, and the JSON file each run is appended to as it finishes."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from app.core.host import machine
from app.jobs.base import MemoryContext
from app.jobs.recovery.metrics import target_met
from app.jobs.recovery.robust import held_out_walks
from app.jobs.recovery.run import run, set_up
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.speed_configs import (ALTERNATIVES, EQUAL, ONLY_SEARCH, PAPER, PERTURBED_SETS,
                                                       _documented, _paper_by_seed, _runs_of, _table2_rows, _uniform,
                                                       by_config)
from app.jobs.recovery.reproduce.speed_step import (pairs_row, profiles, scaling_markdown, scaling_row, speed_ratios,
                                                    variants)


def _search_row(part: str, lost, seed: int, data: dict) -> dict:
    d = json.loads(json.dumps({**ONLY_SEARCH, **data}))
    d["damage"] = {"lost_legs": list(lost)}
    d.setdefault("search", {})["seed"] = seed
    t = time.perf_counter()
    s = run(RecoverySpec(**d), MemoryContext()).summary
    wall = time.perf_counter() - t
    half = next((c for c in (s.get("robustness") or {}).get("cases", []) if c["name"] == "dt_half"), None)
    return {"part": part, "lost_legs": list(lost), "seed": seed, "spec": d, "wall_s": wall,
            "fitness": s["best"]["fitness"], "metrics": s["best"]["metrics"], "params": s["best"]["params"],
            "target_met": s["best"]["target_met"], "half_step_met": None if half is None else half["target_met"],
            "search": s["search"], "evaluations": s["timing"]["evaluations"], "sim_steps": s["timing"]["sim_steps"],
            "cut_steps_saved": s["timing"].get("cut_steps_saved", 0),
            "time_to_target_s": s["timing"].get("time_to_target_s"),
            "curve": [[r["generation"], r["best"], r["evaluations"]] for r in s["history"] if not r.get("provisional")],
            "walks_cut": sum(r.get("cut", 0) for r in s["history"]),
            "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}


def paper_row(lost, seed: int, docs: Path) -> dict:
    """The paper's DE (30 x 60, 10 s walks) with its losing walks cut short; for a seed the
    docs hold (Table II), whether the answer is the full-walk run's, bit for bit."""
    r = _search_row("paper", lost, seed, PAPER | {"search": PAPER["search"] | {"cut_walks": True}})
    doc = _documented(lost, seed, _table2_rows(docs))
    r["documented_params"] = None if doc is None else doc["best_params"]
    r["identical_to_documented"] = None if doc is None else doc["best_params"] == r["params"]
    return r


def check_rows(docs: Path, log: Callable[[str], None] = print, done: set | None = None):
    """Every nominal answer of docs/recovery_robust_w20.json at the default step (DE 12 x 12
    on every feasible 1- and 2-leg loss) searched again with cut walks: same answer?"""
    dt = RecoverySpec().sim.timestep_s
    path = docs / "recovery_robust_w20.json"
    for doc in json.loads(path.read_text()) if path.exists() else []:
        if doc["mode"] != "nominal" or doc["timestep_s"] != dt or (done and tuple(doc["lost_legs"]) in done):
            continue
        data = {"search": {"population": doc["population"], "generations": doc["generations"], "cut_walks": True},
                "objective": {"weights": doc["weights"]}, "robustness": {"cases": []}}
        r = _search_row("check", tuple(doc["lost_legs"]), doc["seed"], data)
        r["identical_to_documented"] = r["params"] == doc["best_params"]
        log(f"check legs {doc['lost_legs']}: same answer as recovery_robust_w20.json: {r['identical_to_documented']}, "
            f"{r['cut_steps_saved']} of {r['sim_steps'] + r['cut_steps_saved']} steps saved")
        yield r


def control_row(lost, seed: int, docs: Path) -> dict:
    """The random-search control of the paper-size job (30 x 60 after the first generation,
    the control's own stream of ``seed``) with its walks cut once they cannot beat its best
    so far (``controls.cut_walks``), then with full walks, on the same job: the same best
    bit for bit? Its steps and wall time both ways, and Table II's documented control F for
    this seed beside them."""
    from app.jobs.recovery.run import random_control, set_up

    spec = RecoverySpec(damage={"lost_legs": list(lost)}, search={"seed": seed}, **ONLY_SEARCH)
    job = set_up(spec)
    out = {}
    try:
        for name, cuts in (("cut", True), ("full", False)):
            t = time.perf_counter()
            o = random_control(job, PAPER["search"]["generations"], MemoryContext(), cuts=cuts)
            out[name] = {"fitness": o.best_fitness, "params": o.best_x.tolist(), "evaluations": o.evaluations,
                         "sim_steps": int(o.totals["sim_steps"]),
                         "cut_steps_saved": int(o.totals.get("cut_steps_saved", 0)),
                         "walks_cut": sum(r.get("cut", 0) for r in o.history), "wall_s": time.perf_counter() - t}
    finally:
        job.close()
    doc = _documented(lost, seed, _table2_rows(docs))
    cut, full = out["cut"], out["full"]
    return {"part": "control", "lost_legs": list(lost), "seed": seed, **out,
            "identical": cut["params"] == full["params"] and cut["fitness"] == full["fitness"],
            "documented_fitness": doc["random_search"]["fitness"] if doc and doc.get("random_search") else None,
            "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}


def coarse_row(lost, seed: int, docs: Path) -> dict:
    """Coarse-to-fine's first half: the equal-quality configuration searched at twice the
    step (half the steps per walk), its answer then judged at the default step."""
    from app.jobs.recovery.reproduce.documented_answers import answers_metrics
    from app.jobs.recovery.metrics import TARGET, fitness

    dt = RecoverySpec().sim.timestep_s
    cfg = EQUAL | {"search": EQUAL["search"] | {"generations": 2 * EQUAL["search"]["generations"]},
                   "sim": {"timestep_s": 2 * dt}}
    r = _search_row("coarse", lost, seed, cfg)
    m = answers_metrics([{"lost_legs": list(lost), "best_params": r["params"]}], dt)
    w = RecoverySpec().objective
    r["at_default_step"] = {"fitness": float(fitness(m, w.weights, w.units)[0]),
                            "metrics": {k: v[0].item() for k, v in m.items()},
                            "target_met": TARGET.met({k: v[0] for k, v in m.items()})}
    return r


def throughput(spec: RecoverySpec, repeats: int = 2) -> dict:
    """(a-c) on the spec's population of uniform random candidates."""
    from mujoco import rollout

    from app.jobs.recovery.run import set_up

    job = set_up(spec)
    ev = job.ev
    x = _uniform(job, spec.search.population)
    ctrl, state = ev.controls(x)
    # the raw rollout writes into arrays allocated and touched beforehand, so it times the
    # simulation, not the first touch of a few hundred MB of fresh output
    out = {"state": np.zeros((ctrl.shape[0], ctrl.shape[1], ev._nstate)),
           "sensordata": np.zeros((ctrl.shape[0], ctrl.shape[1], ev.model.nsensordata))}
    raw, evaluator = [], []
    try:
        with rollout.Rollout(nthread=ev.nthread) as runner:
            runner.rollout(ev.model, ev._pool.datas, state, ctrl[:, :10])  # warm the pool
            for _ in range(repeats):  # interleaved, so a change of load hits both alike
                t = time.perf_counter()
                runner.rollout(ev.model, ev._pool.datas, state, ctrl, **out)
                raw.append(ctrl.shape[0] * ctrl.shape[1] / (time.perf_counter() - t))
                t = time.perf_counter()
                r = ev.evaluate(x)
                evaluator.append(r.sim_steps / (time.perf_counter() - t))
    finally:
        job.close()
    a, b = float(np.median(raw)), float(np.median(evaluator))
    # the step's settings measured (RobotEntry.model: explicit contact pairs, island discovery)
    step = {"contact_pairs": int(job.model.npair),
            "island_discovery": not job.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND}
    return {"raw_steps_per_s": a, "evaluator_steps_per_s": b, "ratio": b / a, "threads": ev.nthread, "step": step}


def throughput_row() -> dict:
    """The bench's (a-c): raw rollout and evaluator steps/s on legs 1 & 6, interleaved."""
    spec = RecoverySpec(damage={"lost_legs": [1, 6]}, sim={"duration_s": 5.0}, **ONLY_SEARCH)
    return {"part": "throughput"} | throughput(spec, repeats=3) | {"load": os.getloadavg()[0]}


PARTS: dict[str, Callable[..., dict]] = {
    "coarse": coarse_row,
    "cap": lambda lost, seed, docs: speed_ratios(lost, seed=seed + 1),
    "paper": paper_row,
    "control": control_row,
    "fast": lambda lost, seed, docs: _search_row("fast", lost, seed, {"preset": "fast"}),
    "equal": lambda lost, seed, docs: _search_row("equal", lost, seed, EQUAL),
} | {f"alt_{name}": (lambda cfg, part: lambda lost, seed, docs: _search_row(part, lost, seed, cfg))(cfg, f"alt_{name}")
     for name, cfg in ALTERNATIVES.items()}


def measure(parts: list[str], seeds: int, damages: list[tuple[int, ...]], raw: Path, docs: Path,
            log: Callable[[str], None] = print) -> list[dict]:
    """Every (part, damage, seed) not yet in ``raw``, seed by seed, each written at once;
    "profile" measures the step again."""
    rows = json.loads(raw.read_text()) if raw.exists() else []
    done = {(r["part"], tuple(r["lost_legs"]), r["seed"]) for r in by_config(rows) if r["part"] in PARTS}
    if "profile" in parts:
        rows = [r for r in rows if r["part"] != "profile"] + [{"part": "profile", "rows": profiles(),
                                                              "load": os.getloadavg()[0], "cores": os.cpu_count()}]
        _save(rows, raw)
        log("step profile measured")
    if "check" in parts:
        checked = {tuple(r["lost_legs"]) for r in rows if r["part"] == "check"}
        for r in check_rows(docs, log, checked):
            rows.append(r)
            _save(rows, raw)
    if "throughput" in parts:
        rows = [r for r in rows if r["part"] != "throughput"] + [throughput_row()]
        _save(rows, raw)
    if "scaling" in parts:  # kept beside earlier ones, as the variants
        rows.append(scaling_row())
        _save(rows, raw)
        log(scaling_markdown(rows[-1])[0])
    if "pairs" in parts:  # kept beside earlier ones, as the variants
        rows.append(pairs_row(docs=docs))
        _save(rows, raw)
        log(f"step settings: {rows[-1]['damages']}, answers identical: {rows[-1]['identical']}")
    if "variants" in parts:  # each measurement is kept: the machine's noise shows between them
        rows.append(variants(docs=docs))
        _save(rows, raw)
        log("physics variants measured")
    seeds_of = {"cap": 1, "coarse": 1}  # the speed cap and the coarse search: once per damage
    for seed in range(seeds):
        for lost in damages:
            for part in [p for p in parts if p in PARTS]:
                if (part, tuple(lost), seed) in done or seed >= seeds_of.get(part, seeds):
                    continue
                rows.append(PARTS[part](lost, seed, docs))
                _save(rows, raw)
                r = rows[-1]
                if part == "cap":
                    log(f"cap legs {lost}: largest ratio {r['max_ratio']:.2f} over {r['walkers']} walks")
                    continue
                if part == "control":
                    log(f"control legs {lost} seed {seed}: same best {r['identical']}, F {r['cut']['fitness']:.2f}, "
                        f"steps {r['cut']['sim_steps']} against {r['full']['sim_steps']}, "
                        f"{r['cut']['wall_s']:.0f} s against {r['full']['wall_s']:.0f} s at load {r['load']:.1f}")
                    continue
                log(f"{part} legs {lost} seed {seed}: F {r['fitness']:.2f}, target {r['target_met']} (half step "
                    f"{r['half_step_met']}), {r['search']['stop_reason']} after {r['search']['generations_run']} "
                    f"generations, {r['sim_steps']} steps, {r['wall_s']:.0f} s at load {r['load']:.1f}")
    if "perturbed" in parts:  # after the searches above: it re-walks their answers (every seed that has all three)
        # a row walked under other cases than today's (their labels say: issue 47's floor) is walked again
        from app.jobs.recovery.cases import walking_cases
        from app.robots.catalog import get_robot

        labels = [c.label for c in walking_cases(get_robot(RecoverySpec().robot).geometry.total_mass,
                                                 RecoverySpec().robustness.cases)]
        rows = [r for r in rows if r["part"] != "perturbed" or r["labels"] == labels]
        have = {(tuple(r["lost_legs"]), r["seed"]) for r in rows if r["part"] == "perturbed"}
        for r in perturbed_rows(rows, _table2_rows(docs), damages, have):
            rows.append(r)
            _save(rows, raw)
            log(f"perturbed legs {r['lost_legs']} seed {r['seed']}: " + ", ".join(
                f"{name} {sum(v['cases_met'])}/{len(v['cases_met'])} cases, {v['held_out_met']}/{r['held_out_n']} "
                "held out" for name, v in r["sets"].items()))
    return rows


def append_part(raw: Path, row: dict) -> None:
    """``row`` after the file's rows: a measurement made again is kept beside the earlier
    ones (each with its load: on a shared machine one measurement is not the machine's)."""
    rows = json.loads(raw.read_text()) if raw.exists() else []
    _save(rows + [row], raw)


def _save(rows: list[dict], raw: Path) -> None:
    raw.parent.mkdir(parents=True, exist_ok=True)
    tmp = raw.with_suffix(".part")
    tmp.write_text(json.dumps(rows, indent=1))
    tmp.replace(raw)


def _answers_of(rows: list[dict], lost, table2: list[dict]) -> dict[str, dict[int, dict]]:
    """PERTURBED_SETS' answers (their parameters) on ``lost``, by seed; the paper DE's from
    this page's runs, else Table II's (``rows`` labelled by by_config)."""
    out = {name: {k: r["params"] for k, r in _runs_of(rows, part, lost).items()}
           for name, part in PERTURBED_SETS.items() if part != "paper"}
    return out | {"paper DE": _paper_by_seed(rows, lost, table2, lambda r: r["params"], lambda d: d.get("best_params"))}


def perturbed_rows(rows: list[dict], table2: list[dict], damages, done: set):
    """A row per damage and seed not in ``done`` (yielded as each is done): the answers of
    PERTURBED_SETS for that seed re-walked under every named case (one batched rollout per set
    and damage) and on the seed's held-out random models (one rollout per seed), judged by
    the target, as a job's robustness block judges its answer."""
    for lost in damages:
        answers = _answers_of(by_config(rows), lost, table2)
        seeds = sorted(set.intersection(*(set(a) for a in answers.values())) - {k for d, k in done if d == tuple(lost)})
        if not seeds:
            continue
        job = set_up(RecoverySpec(damage={"lost_legs": list(lost)}))
        walk_s, n = job.spec.sim.duration_s, job.spec.robustness.held_out
        try:
            judged = {}
            for name, a in answers.items():
                x = np.array([list(a[k].values()) for k in seeds])
                cases = job.rob_ev.evaluate_all(x).metrics
                judged[name] = [[bool(target_met({key: v[i, c] for key, v in cases.items()}, walk_s))
                                 for c in range(len(job.cases))] for i in range(len(seeds))]
            for i, seed in enumerate(seeds):
                x = np.array([list(answers[name][seed].values()) for name in answers])
                _, r = held_out_walks(job.mspec, job.robot, job.seq, job.ev.cfg, x, seed, n)
                held = [sum(bool(target_met({key: v[j, k] for key, v in r.metrics.items()}, walk_s)) for k in range(n))
                        for j in range(len(answers))]
                yield {"part": "perturbed", "lost_legs": list(lost), "seed": seed, "held_out_n": n,
                       "cases": [c.name for c in job.cases], "labels": [c.label for c in job.cases],
                       "sets": {name: {"cases_met": judged[name][i], "held_out_met": held[j]}
                                for j, name in enumerate(answers)},
                       "load": os.getloadavg()[0], "cores": os.cpu_count(), "machine": machine()}
        finally:
            job.close()

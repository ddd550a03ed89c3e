"""Issue 47's "choose answers that hold": the robust choice (spec ``choice.mode: robust``)
against today's answer (the best F) and against a nominal search given the choice's walks as
more generations, on the four Table II damages, closed loop, at the default step and the
paper's budget; every answer judged on the same held-out random models (the held-out stream
of a seed no search uses). `gaitmend reproduce recovery-choice --write-docs`; each finished
job is appended to docs/recovery_choice.json when it ends, and a re-run skips those already
there at this code version.

Per damage and seed two jobs run:

- ``robust``: the search (DE P x G) and the robust choice among its final population
  (``models`` random models); its summary names the best-F member's parameters too, so the
  arm ``best`` (today's answer, the same search) is judged without a second search;
- ``longer``: the nominal search with G + 1 + ``models`` generations, the same walks as the
  search and the choice together (P x (G + 1) + P x (1 + models)), its best F the answer.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger, current_runs, machine_time
from app.jobs.recovery.reproduce import science_files
from app.jobs.recovery.reproduce.randomised_check import HELD_OUT_SEED, KEEP, _rate
from app.jobs.recovery.reproduce.table2_damages import run_seed_major
from app.jobs.reporting import md_table, missing, progress_note

JSON = "docs/recovery_choice.json"
COMMAND = "gaitmend reproduce recovery-choice --write-docs"
SCIENCE = science_files.BASE + ("app/optim/de.py",)
JOBS = ("robust", "longer")
ARMS = ("best", "robust", "longer")  # the page's columns: today's answer, the choice, the longer search
WORDS = {"best": "best F (today)", "robust": "robust choice", "longer": "longer search, best F"}
SCENARIOS = ((3, 4), (1, 6), (1,), (4,))  # Table II's four damages; legs 3 & 4 (the one that misses) first


class ChoiceParams(BaseModel):
    seeds: int = Field(3, ge=1, le=100, description="seeds per damage (the issue asks for 3)")
    population: int = Field(30, ge=4, le=1000, description="DE population (the paper's 30)")
    generations: int = Field(60, ge=1, le=1000, description="the search's generations (the paper's 60); the longer "
                                                            "search gets 1 + models more")
    models: int = Field(20, ge=1, le=200, description="random models the choice walks each member on")
    held_out: int = Field(40, ge=20, le=200, description="held-out random models every answer is judged on")
    json_out: Path | None = Field(Path(JSON), description="the ledger: each job is appended when it ends")


def job_spec(p: ChoiceParams, lost: tuple[int, ...], seed: int, job: str) -> dict:
    gens = p.generations if job == "robust" else p.generations + 1 + p.models
    d = {"damage": {"lost_legs": list(lost)}, "control": {"mode": "closed_loop"},
         "search": {"population": p.population, "generations": gens, "seed": seed},
         "controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 0}}
    if job == "robust":
        d["choice"] = {"mode": "robust", "models": p.models}
    return d


def judge(lost: tuple[int, ...], x: np.ndarray, p: ChoiceParams) -> dict:
    """An answer on the nominal model and the held-out models, closed loop, 10 s walks."""
    from app.jobs.recovery.metrics import target_met
    from app.jobs.recovery.robust import held_out
    from app.jobs.recovery.run import set_up
    from app.jobs.recovery.spec import RecoverySpec

    spec = RecoverySpec.parse({"damage": {"lost_legs": list(lost)}, "control": {"mode": "closed_loop"}})
    job = set_up(spec)
    try:
        def met(m: dict) -> bool | None:
            return target_met(m, spec.sim.duration_s)

        nominal = {k: (bool(v[0, 0]) if k == "fell" else float(v[0, 0]))
                   for k, v in job.ev.evaluate_all(x).metrics.items() if k in KEEP}
        ho, _ = held_out(job.mspec, job.robot, job.seq, job.ev.cfg, x, HELD_OUT_SEED, p.held_out, met)
    finally:
        job.close()
    models = [{k: m["metrics"][k] for k in KEEP} | {"target_met": m["target_met"]} for m in ho["models"]]
    return {"nominal": nominal | {"target_met": met(nominal)}, "held_out": models, "met": ho["met"], "n": ho["n"]}


def run_job(p: ChoiceParams, lost: tuple[int, ...], seed: int, job: str) -> dict:
    from app.jobs.base import MemoryContext
    from app.jobs.recovery.run import run
    from app.jobs.recovery.spec import RecoverySpec

    spec = RecoverySpec.parse(job_spec(p, lost, seed, job))
    s = run(spec, MemoryContext()).summary
    names = s["bounds"]["names"]
    out = {"job": job, "lost_legs": list(lost), "seed": seed, "generations": spec.search.generations,
           "evaluations": s["timing"]["evaluations"], "sim_steps": s["timing"]["sim_steps"],
           "wall_s": s["timing"]["wall_s"], "arms": {}}
    answers = {("robust" if job == "robust" else "longer"): s["best"]["params"]}
    if job == "robust":
        answers["best"] = s["choice"]["best_fitness_params"]
        out["choice"] = {k: v for k, v in s["choice"].items() if k != "best_fitness_params"}
    for arm, params in answers.items():
        out["arms"][arm] = {"params": params, "judged": judge(lost, np.array([params[n] for n in names]), p)}
    return out


def run_choice(p: ChoiceParams, log: Callable[[str], None] = print) -> str:
    planned = len(SCENARIOS) * p.seeds * len(JOBS)
    led = Ledger(p.json_out, "recovery-choice", COMMAND, p.model_dump(mode="json"), SCIENCE, planned=planned)
    run_seed_major(led, SCENARIOS, p.seeds, JOBS, lambda lost, seed, job: job_spec(p, lost, seed, job)
                   | {"held_out": p.held_out}, lambda lost, seed, job: run_job(p, lost, seed, job), log)
    return render([led.data])


# -- the page ---------------------------------------------------------------------------------

def _triples(runs: list[dict]) -> dict[tuple, dict[str, dict]]:
    """{(damage, seed): {arm: its judged answer}} for the damages and seeds with both jobs in."""
    jobs: dict[tuple, dict[str, dict]] = {}
    for r in runs:
        res = r["result"]
        jobs.setdefault((tuple(res["lost_legs"]), res["seed"]), {})[res["job"]] = res
    out = {}
    for k, v in sorted(jobs.items()):
        if all(j in v for j in JOBS):
            out[k] = {a: v[j]["arms"][a] for j in JOBS for a in v[j]["arms"]} | {"choice": v["robust"]["choice"]}
    return out


def render(datas: list) -> str:
    from app.jobs.stats import paired, paired_text

    data = datas[0]
    runs = current_runs(data) if data else []
    if not runs:
        return missing(JSON, COMMAND)
    p, tri = data["params"], _triples(runs)
    out = [f"The robust choice (choice.mode robust: of DE {p['population']} x {p['generations']}'s final population, "
           f"the gait that meets the target on the nominal model and on the most of {p['models']} random models) "
           f"against the same search's best F (today's answer) and against a nominal search of "
           f"{p['generations'] + 1 + p['models']} generations (the same walks as search and choice together), closed "
           f"loop, 10 s walks at the default step; each answer judged on the same {p['held_out']} held-out random "
           f"models (held-out stream of seed {HELD_OUT_SEED}, not a search seed). {len(runs)} of "
           f"{data.get('planned')} planned jobs are in ({len(tri)} complete damage-and-seed triples).", ""]
    if not tri:
        return "\n".join(out) + progress_note(data, len(runs))
    rows = []
    for lost in sorted({k[0] for k in tri}, key=lambda l: SCENARIOS.index(l) if l in SCENARIOS else 99):
        ts = [v for k, v in tri.items() if k[0] == lost]
        cells = []
        for a in ARMS:
            k, n = sum(v[a]["judged"]["met"] for v in ts), sum(v[a]["judged"]["n"] for v in ts)
            falls = sum(m["fell"] for v in ts for m in v[a]["judged"]["held_out"])
            cells.append(f"{_rate(k, n)}, {falls} fell")
        same = sum(v["choice"]["chosen"] == v["choice"]["best_fitness_member"] for v in ts)
        rows.append([" & ".join(map(str, lost)), len(ts), *cells, f"{same}/{len(ts)}"])
    out += [md_table(["damage", "seeds", *(f"{WORDS[a]}: held-out met [95 % Wilson], falls" for a in ARMS),
                      "choice kept the best F"], rows), ""]
    share = {a: [v[a]["judged"]["met"] / v[a]["judged"]["n"] for v in tri.values()] for a in ARMS}
    if len(tri) >= 2:
        for a, b in (("robust", "best"), ("robust", "longer")):
            r = paired(share[a], share[b], names=(WORDS[a], WORDS[b]))
            out.append(f"Held-out share, {WORDS[a]} - {WORDS[b]} (one pair per damage and seed): "
                       f"{paired_text(r, digits=3)}.")
        out.append("")
    out.append(f"Machine time of all jobs: {machine_time(data)['wall_s']:.0f} s wall.")
    return "\n".join(out) + "\n" + progress_note(data, len(runs))

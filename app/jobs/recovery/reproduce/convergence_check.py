"""The timestep convergence study (`gaitmend reproduce recovery-convergence`): search at a
timestep, re-simulate the answers at half of it and judge them by the rule
(app/jobs/recovery/reproduce/convergence.py), kept in docs/recovery_convergence.json, and
its page and sections."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.base import MemoryContext
from app.jobs.reporting import marked, missing
from app.jobs.recovery.reproduce.documented_answers import answers_metrics, documented_answers
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.table2_damages import SCENARIOS, _name, _save_rows


# -- the convergence rule on a set of recovered answers -----------------------------------------

def convergence_report(answers: list[dict], timestep: float) -> dict:
    from app.jobs.recovery.reproduce.convergence import check, halving_deltas

    a, b = answers_metrics(answers, timestep), answers_metrics(answers, timestep / 2)
    d = halving_deltas(a, b)
    return check(d) | {"timestep_s": timestep,
                       "per_answer": [{"lost_legs": ans["lost_legs"], "seed": ans.get("seed"),
                                       "best_params": ans["best_params"],
                                       "x_cm": [100 * float(a["x_f_m"][i]), 100 * float(b["x_f_m"][i])],
                                       "yaw_deg": [float(a["yaw_f_deg"][i]), float(b["yaw_f_deg"][i])],
                                       "y_cm": [100 * float(a["y_f_m"][i]), 100 * float(b["y_f_m"][i])]}
                                      for i, ans in enumerate(answers)]}


CONVERGENCE_BUDGET = (16, 12)  # DE population x generations of the convergence searches


def convergence_study(timestep: float, seeds: int = 2, population: int = CONVERGENCE_BUDGET[0],
                      generations: int = CONVERGENCE_BUDGET[1], log: Callable[[str], None] = print) -> dict:
    """Searches the paper's four damages at ``timestep`` (small DE budget, no controls),
    then re-simulates every answer at half the step: the rule's verdict for that step."""
    answers = []
    for seed in range(seeds):
        for lost in SCENARIOS:
            spec = RecoverySpec(damage={"lost_legs": list(lost)}, sim={"timestep_s": timestep},
                                search={"population": population, "generations": generations, "seed": seed},
                                controls={"random_search": False}, robustness={"cases": []})
            s = run(spec, MemoryContext()).summary
            answers.append({"lost_legs": list(lost), "seed": seed, "best_params": s["best"]["params"]})
            log(f"{1000 * timestep:g} ms, legs {lost} seed {seed} searched")
    return convergence_report(answers, timestep) | {"set": "searched", "population": population,
                                                    "generations": generations}


# What each verdict's answers are (a verdict's "set"): the table's words, and the per-answer
# list's heading adds "at that step" and, for the searches, their budget.
SET_WORDS = {"searched": "searched at the step", "documented": "every answer the docs report",
             "paper_damages": "the docs' answers for Table II's four damages"}


def _and(items: list) -> str:
    items = [str(i) for i in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def which_text(r: dict) -> str:
    """The heading words of a verdict's answers; a search's budget as the verdict records it
    (the verdicts written before it was recorded: the command's, CONVERGENCE_BUDGET), its
    damages and seeds from its answers."""
    words = SET_WORDS.get(r.get("set"), "")
    if r.get("set") == "searched":
        pop, gens = r.get("population", CONVERGENCE_BUDGET[0]), r.get("generations", CONVERGENCE_BUDGET[1])
        seeds = sorted({a["seed"] for a in r["per_answer"]})
        losses = list(dict.fromkeys(tuple(a["lost_legs"]) for a in r["per_answer"]))
        damages = ("the four Table II damages" if sorted(losses) == sorted(SCENARIOS)
                   else _and([_name(l).lower() for l in losses]))
        return f"searched at that step (DE {pop} x {gens}, {damages}, seed{'s' * (len(seeds) > 1)} {_and(seeds)})"
    return f"{words} at that step" if words else ""


def convergence_table(reports: list[dict]) -> list[str]:
    """The rule and one row per (step, set of answers): the lines convergence_markdown starts with."""
    from app.jobs.recovery.reproduce.convergence import RULE_TEXT

    out = [f"Rule: {RULE_TEXT}.", "",
           "| step | answers | forward: max change | drift: median / max change (cm) | yaw: median / max change (deg) "
           "| answers within drift and yaw bands | passes |", "|---|---|---|---|---|---|---|"]
    for r in reports:
        out.append(f"| {1000 * r['timestep_s']:g} ms -> {500 * r['timestep_s']:g} ms | {r['answers']} "
                   f"({SET_WORDS.get(r.get('set'), '')}) | "
                   f"{100 * r['max_forward_rel']:.1f} % | {100 * r['median_lateral_m']:.1f} / {100 * r['max_lateral_m']:.1f} | "
                   f"{r['median_yaw_deg']:.1f} / {r['max_yaw_deg']:.1f} | {100 * r['share_within']:.0f} % | "
                   f"{'yes' if r['passes'] else '**no**'} |")
    return out


CONVERGENCE_JSON = "docs/recovery_convergence.json"
CONVERGENCE_COMMAND = "gaitmend reproduce recovery-convergence --timesteps 0.004,0.002,0.001"
CONVERGENCE_SECTIONS = ("recovery-convergence", "recovery-convergence-answers")  # the table, the per-answer lists


def render_convergence_table(datas: list) -> str:
    if datas[0] is None:
        return missing(CONVERGENCE_JSON, CONVERGENCE_COMMAND)
    return "\n".join(convergence_table(datas[0])) + "\n"


def render_convergence_answers(datas: list) -> str:
    """docs/recovery_convergence.md's per-answer lists, from docs/recovery_convergence.json."""
    if datas[0] is None:
        return missing(CONVERGENCE_JSON, CONVERGENCE_COMMAND)
    return "\n".join(convergence_answers(datas[0]))


def convergence_markdown(reports: list[dict]) -> str:
    return "\n".join(convergence_table(reports) + [""] + convergence_answers(reports))


def convergence_page(reports: list[dict]) -> str:
    """docs/recovery_convergence.md as the command writes it: a title, then the table and the
    per-answer lists inside their generated-section markers (`gaitmend docs` re-renders them)."""
    out = "# Timestep convergence of the recovered answers\n"
    for name, render in zip(CONVERGENCE_SECTIONS, (render_convergence_table, render_convergence_answers)):
        out += f"\n{marked(name, CONVERGENCE_COMMAND, render([reports]))}\n"
    return out


def convergence_answers(reports: list[dict]) -> list[str]:
    """Per verdict, every answer's x, yaw and y at the step and at half of it."""
    out = []
    for r in reports:
        out.append(f"Per answer at {1000 * r['timestep_s']:g} ms, {which_text(r)} (x cm, yaw deg: at the step -> at half of it):")
        for a in r["per_answer"]:
            out.append(f"- {_name(tuple(a['lost_legs']))}, seed {a['seed']}: x {a['x_cm'][0]:.1f} -> {a['x_cm'][1]:.1f}, "
                       f"yaw {a['yaw_deg'][0]:.1f} -> {a['yaw_deg'][1]:.1f}, y {a['y_cm'][0]:.1f} -> {a['y_cm'][1]:.1f}")
        out.append("")
    return out


class ConvergenceParams(BaseModel):
    timesteps: str = Field("0.004,0.002,0.001", description="steps to test, comma-separated seconds")
    seeds: int = Field(2, ge=1, le=20, description="seeds per scenario (small DE searches)")
    out: Path = Field(Path("docs/recovery_convergence.md"), description="markdown to write")
    raw: Path = Field(Path("docs/recovery_convergence.json"),
                      description="the verdicts with every answer's parameters; a step's earlier verdict is replaced")


SET_ORDER = {"searched": 0, "paper_damages": 1, "documented": 2}


def _convergence(p: ConvergenceParams, log: Callable[[str], None]) -> str:
    def merge(new: list[dict]) -> list[dict]:  # a (step, set) verdict replaces the earlier one
        old = json.loads(p.raw.read_text()) if p.raw.exists() else []
        keys = {(r["timestep_s"], r["set"]) for r in new}
        rows = sorted([r for r in old if (r["timestep_s"], r.get("set")) not in keys] + new,
                      key=lambda r: (-r["timestep_s"], SET_ORDER.get(r.get("set"), 3)))
        _save_rows(rows, p.raw)
        return rows

    reps = [convergence_study(float(t), seeds=p.seeds, log=log) for t in p.timesteps.split(",")]
    merge(reps)
    # The rule on everything the docs report at each step (Table II, the robust comparisons'
    # nominal answers and these searches), and on those for the paper's four damages: the
    # verdicts the docs and tests quote.
    more = []
    for r in reps:
        answers = documented_answers(r["timestep_s"], p.raw.parent)
        if len(answers) > r["answers"]:
            more.append(convergence_report(answers, r["timestep_s"]) | {"set": "documented"})
            paper = [a for a in answers if tuple(a["lost_legs"]) in SCENARIOS]
            more.append(convergence_report(paper, r["timestep_s"]) | {"set": "paper_damages"})
    reports = merge(more)
    p.out.parent.mkdir(parents=True, exist_ok=True)
    p.out.write_text(convergence_page(reports))
    return convergence_markdown(reports)

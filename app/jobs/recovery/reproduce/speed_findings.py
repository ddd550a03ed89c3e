"""The speed page's comparisons: the equal-quality configuration against the paper's DE (at
the same budget and paired by seed), the short walks against their controls, the answers
under perturbations, and the gains of each change."""

from __future__ import annotations

import json
import statistics

from app.jobs.recovery.reproduce.speed_configs import (ALTERNATIVES, EQUAL, MORE_STEPS, PERTURBED_SETS, SAME_STEPS,
                                                       SCENARIOS, SHORT_ROWS, _paper_fitness, _paper_half_step,
                                                       _runs_of)
from app.jobs.recovery.reproduce.speed_step import STEP_SETTINGS, STEP_TEXT
from app.jobs.recovery.reproduce.speed_tables import _name, _spread


def _at_budget(rows: list[dict], lost, eq: list[dict]) -> list[float]:
    """The paper DE's best F (its runs' history) once it had simulated as many steps as the
    equal-quality search of the same seed (its walks are all full: steps per walk from its
    own totals, the steps its cut walks saved included)."""
    out = []
    for r in eq:
        paper = next((p for p in rows if p["part"] == "paper" and tuple(p["lost_legs"]) == lost
                      and p["seed"] == r["seed"]), None)
        if paper is not None:
            walks = r["sim_steps"] * paper["evaluations"] / (paper["sim_steps"] + paper["cut_steps_saved"])
            out.append(max((b for _, b, n in paper["curve"] if n <= walks), default=float("nan")))
    return out


def _walks_to(run: dict, f: float) -> str:
    """How many walks ``run`` had evaluated when its best first reached ``f`` (its history),
    with the share of its whole budget, or "not reached"."""
    hit = next((n for _, b, n in run["curve"] if b >= f), None)
    return "not reached" if hit is None else f"{hit:,} ({100 * hit / run['evaluations']:.0f} %)"


def summary_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage: the paper DE's F against the equal-quality configuration's on the same
    seeds, and the fast preset's time to the target, in steps (machine-independent) and
    seconds (this machine, at its load)."""
    out = ["| damage | paper DE F, median [range] (seeds) | equal-quality F | equal >= paper, same seed | "
           "paper DE F after as many steps as the equal-quality search | "
           "equal-quality answers meeting the target (also at half the step) | equal-quality steps / paper DE steps | "
           "equal-quality run, whole budget (s) | equal-quality walks to the same seed's paper DE F | "
           "fast preset: steps to the target | fast preset: time to the target (s) | fast preset: met at half the "
           "step |", "|---" * 12 + "|"]
    for lost in SCENARIOS:
        eq = [r for r in rows if r["part"] == "equal" and tuple(r["lost_legs"]) == lost]
        fast = [r for r in rows if r["part"] == "fast" and tuple(r["lost_legs"]) == lost]
        paper = _paper_fitness(rows, lost, table2)
        if not (eq or fast):
            continue
        same = _equal_with_paper(rows, lost, table2)
        wins, pairs = sum(r["fitness"] >= f for r, f in same), len(same)
        ps = [r["sim_steps"] + r["cut_steps_saved"] for r in rows if r["part"] == "paper" and tuple(r["lost_legs"]) == lost]
        ratio = f"{statistics.median(r['sim_steps'] for r in eq) / statistics.median(ps):.2f}" if ps and eq else "-"
        met = f"{sum(r['target_met'] for r in eq)} ({sum(bool(r['half_step_met']) for r in eq)}) of {len(eq)}"
        ttt = [r["time_to_target_s"] for r in fast if r["time_to_target_s"] is not None]
        early = _at_budget(rows, lost, eq)
        reach = ", ".join(_walks_to(r, paper[r["seed"]]) for r in eq if r["seed"] in paper) or "-"
        out.append(f"| {_name(lost)} | {_spread(list(paper.values()), '{:.2f}')} ({len(paper)}) | "
                   f"{_spread([r['fitness'] for r in eq], '{:.2f}')} ({len(eq)}) | {wins} of {pairs} | "
                   f"{_spread(early, '{:.2f}')} ({len(early)}) | {met} | {ratio} | "
                   f"{_spread([r['wall_s'] for r in eq], '{:.0f}')} at load {_spread([r['load'] for r in eq])} | "
                   f"{reach} | {_spread([r['sim_steps'] for r in fast], '{:,.0f}')} | {_spread(ttt)} | "
                   f"{sum(bool(r['half_step_met']) for r in fast)} of {len(fast)} |")
    return out + [""]


def _equal_with_paper(rows: list[dict], lost, table2: list[dict]) -> list[tuple[dict, float]]:
    """The equal-quality runs on ``lost`` whose seed has a paper DE F (``_paper_fitness``),
    each with that F, by seed."""
    paper = _paper_fitness(rows, lost, table2)
    eq = [r for r in rows if r["part"] == "equal" and tuple(r["lost_legs"]) == tuple(lost) and r["seed"] in paper]
    return [(r, paper[r["seed"]]) for r in sorted(eq, key=lambda r: r["seed"])]


def paired_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage: the equal-quality configuration's final F against the paper DE's, paired
    by seed (app/jobs/stats.py: mean difference, its interval, Wilcoxon's test, the verdict),
    beside the medians the issue's rule compares: a median at least the paper DE's on a
    handful of seeds is not a difference shown, nor one below it a loss shown."""
    from app.jobs import stats

    out = []
    for lost in SCENARIOS:
        pairs = _equal_with_paper(rows, lost, table2)
        if len(pairs) < 2:
            continue
        a, b = [r["fitness"] for r, _ in pairs], [f for _, f in pairs]
        verdict = "reaches" if statistics.median(a) >= statistics.median(b) else "does not reach"
        r = stats.paired(a, b, names=("equal quality", "paper DE"))
        out.append(f"- {_name(lost)}: median F {statistics.median(a):.2f} against {statistics.median(b):.2f} "
                   f"({verdict} the paper DE's); equal quality minus paper DE, paired by seed: "
                   f"{stats.paired_text(r)}.")
    if not out:
        return []
    return ["The same comparison as a paired test on the seeds both have run (a verdict other than \"not shown\" needs "
            "the interval and the test to agree):", ""] + out + ["", stats.PAIRED_NOTE, ""]


def short_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """search.short_walks (SHORT_ROWS) against its controls on the same seeds: CMA-ES 12 with
    full walks for as many steps (SAME_STEPS) and for more (MORE_STEPS), and the paper DE;
    medians, then paired by seed."""
    from app.jobs import stats

    rows = [r for r in rows if "lost_legs" in r]
    tried = [name for name, cfg in SHORT_ROWS.items() if any(_runs_of(rows, cfg, lost) for lost in SCENARIOS)]
    if not tried:
        return []
    sw = EQUAL["search"]
    more = ALTERNATIVES[MORE_STEPS.removeprefix("alt_")]["search"]
    out = ["## Short walks in the first generations", "",
           "`search.short_walks` (CMA-ES only): the first generations walk for less time and only steer the search. "
           "Their F ranks the candidates, which is all CMA-ES's update uses, and is told as provisional: it never "
           "becomes the answer, and the stop rules pass over it. The answer is the best of the full-walk generations "
           "after them, judged at the default step and at half of it. With `extrapolate` (the default) the short "
           "walk's forward, lateral and yaw displacements are carried to the full walk's length as rates before F, "
           "so that a drift weighs as it would over the full walk; without it, F is the short walk's own. Tried: "
           f"{sw['short_walks']['generations']} generations of {sw['short_walks']['walk_s']:g} s walks, then "
           f"{sw['generations'] + 1 - sw['short_walks']['generations']} of full 10 s walks, CMA-ES 12 (this page's "
           "equal-quality configuration): the steps of CMA-ES 12 x 60 with full walks, its control at equal steps. "
           f"CMA-ES 12 x {more['generations']} with full walks spends more (the steps column). Same seeds in every "
           "column of a row; the paper DE's F and its answers at half the step as in the tables above (else "
           "docs/table2.json's robustness case dt_half).", "",
           f"| damage | configuration | seeds | F | CMA-ES 12 x 60, full walks (same steps) | CMA-ES 12 x "
           f"{more['generations']}, full walks | paper DE | steps: this / 12 x 60 / 12 x {more['generations']} | "
           "whole run (s) | target met (also at half the step) | paper DE: met at half the step |",
           "|---" * 11 + "|"]
    lines = []
    for lost in SCENARIOS:
        same, bigger, paper = _runs_of(rows, SAME_STEPS, lost), _runs_of(rows, MORE_STEPS, lost), _paper_fitness(
            rows, lost, table2)
        half = _paper_half_step(rows, lost, table2)
        for name in tried:
            short = _runs_of(rows, SHORT_ROWS[name], lost)
            seeds = sorted(set(short) & set(same) & set(paper))
            if not seeds:
                continue
            eq = [bigger[k]["fitness"] for k in seeds if k in bigger]
            steps = [statistics.median(r[k]["sim_steps"] for k in seeds) if all(k in r for k in seeds) else None
                     for r in (short, same, bigger)]
            out.append(f"| {_name(lost)} | {name} | {len(seeds)} | "
                       f"{_spread([short[k]['fitness'] for k in seeds], '{:.2f}')} | "
                       f"{_spread([same[k]['fitness'] for k in seeds], '{:.2f}')} | "
                       f"{_spread(eq, '{:.2f}') + ('' if len(eq) in (0, len(seeds)) else f' ({len(eq)})')} | "
                       f"{_spread([paper[k] for k in seeds], '{:.2f}')} | "
                       f"{' / '.join('-' if v is None else f'{v / 1e6:.2f} M' for v in steps)} | "
                       f"{_spread([short[k]['wall_s'] for k in seeds], '{:.0f}')} | "
                       f"{sum(short[k]['target_met'] for k in seeds)} "
                       f"({sum(bool(short[k]['half_step_met']) for k in seeds)}) of {len(seeds)} | "
                       f"{sum(half[k] for k in seeds if k in half)} of {sum(k in half for k in seeds)} |")
            a = [short[k]["fitness"] for k in seeds]
            for control, b in (("CMA-ES 12 x 60 with full walks", [same[k]["fitness"] for k in seeds]),
                               ("the paper DE", [paper[k] for k in seeds])):
                r = stats.paired(a, b, names=(name, control))
                lines.append(f"- {_name(lost)}: {name} minus {control}, paired by seed: {stats.paired_text(r)}.")
    if not lines:  # no seed has a same-steps run and a paper DE F beside the short walks
        return []
    return out + ["", "Paired by seed (the note above says how to read a verdict):", ""] + lines + [""]


def perturbed_markdown(rows: list[dict]) -> list[str]:
    """The answers of PERTURBED_SETS under each named case and on the held-out models, per
    damage (the same seeds in every set), then the short walks paired by seed against each
    control on the models met (named cases and held-out together)."""
    from app.jobs import stats

    rows = [r for r in rows if r["part"] == "perturbed"]
    if not rows:
        return []
    labels, n = rows[0]["labels"], rows[0]["held_out_n"]
    out = ["### The answers on the perturbed robot", "",
           "Each set's answers for the same seeds, re-walked as a job's robustness block walks its answer: under "
           f"every named case and on the {n} held-out random models of the seed (the held-out stream of the job's "
           "seed: the three answers of a seed face the same models), judged by the target. The short walks search "
           "the nominal model only, as do both controls.", "",
           "| damage | answers | seeds | " + " | ".join(labels) + f" | held-out models met (of {n} per seed) |",
           "|---" * (4 + len(labels)) + "|"]
    lines, worse = [], []
    for lost in SCENARIOS:
        got = sorted((r for r in rows if tuple(r["lost_legs"]) == lost), key=lambda r: r["seed"])
        if not got:
            continue
        for name in PERTURBED_SETS:
            met = [sum(r["sets"][name]["cases_met"][c] for r in got) for c in range(len(labels))]
            held = [r["sets"][name]["held_out_met"] for r in got]
            out.append(f"| {_name(lost)} | {name} | {len(got)} | " + " | ".join(f"{m} of {len(got)}" for m in met)
                       + f" | {sum(held)} of {n * len(got)} (median {statistics.median(held):g}) |")
        models = {name: [sum(r["sets"][name]["cases_met"]) + r["sets"][name]["held_out_met"] for r in got]
                  for name in PERTURBED_SETS}
        for control in list(PERTURBED_SETS)[1:]:
            res = stats.paired(models["short walks"], models[control], names=("short walks", control))
            worse += [f"{_name(lost)} (against {control})"] if res["shown"] == "control" else []
            lines.append(f"- {_name(lost)}: models met (of {len(labels) + n}), short walks minus {control}, paired "
                         f"by seed: {stats.paired_text(res)}.")
    verdict = ("Equal quality above is judged on the nominal model, as the issue's rule asks. On the perturbed robot "
               "the short walks' answers are shown less robust on " + "; ".join(worse) + ", and no difference is "
               "shown elsewhere." if worse else "On the perturbed robot no difference from either control is shown.")
    return out + ["", "Paired by seed (the note above says how to read a verdict):", ""] + lines + ["", verdict, ""]


def _frac(num: float, den: float) -> str:
    return f"{100 * num / den:.1f} %" if den else "-"


def gains_markdown(rows: list[dict], table2: list[dict] | None = None) -> list[str]:
    """The table of changes: what each saves, from the runs on this page."""
    by = {p: [r for r in rows if r["part"] == p]
          for p in ("throughput", "check", "paper", "fast", "equal", "pairs", "control")}
    out = ["| change | default job | measured here | command |", "|---|---|---|---|"]
    for r in by["pairs"][-1:]:
        names = [n for n in STEP_SETTINGS if n in r["damages"][0]["us_per_step"]]  # an older row has fewer
        for prev, name in zip(names, names[1:]):
            ups = ", ".join(f"{_name(d['lost_legs'])} {d['us_per_step'][prev]:.1f} -> {d['us_per_step'][name]:.1f} us "
                            f"({d['us_per_step'][prev] / d['us_per_step'][name]:.2f}x)" for d in r["damages"])
            out.append(f"| {STEP_TEXT[name]} | yes | single-thread CPU per step {ups} (load {r['load']:.1f}); the "
                       f"{r['answers']} documented answers "
                       f"{'bit-identical to before' if r['identical'][name] else '**not** identical to before'} | "
                       f"`gaitmend reproduce recovery-speed --parts pairs` |")
    for r in by["throughput"][-1:]:
        out.append(f"| evaluator: each chunk's controls from one gait period, the rollout's output buffers kept "
                   f"(same numbers bit for bit) | yes | through the evaluator {r['evaluator_steps_per_s']:,.0f} "
                   f"steps/s against {r['raw_steps_per_s']:,.0f} raw: ratio {r['ratio']:.2f} (load {r['load']:.1f}) | "
                   f"`gaitmend bench --kind recovery --json` (ratio) |")
    cut = by["paper"] + by["check"]
    if cut:
        same = sum(bool(r["identical_to_documented"]) for r in cut if r["identical_to_documented"] is not None)
        known = sum(r["identical_to_documented"] is not None for r in cut)
        saved = sum(r["cut_steps_saved"] for r in cut)
        total = sum(r["sim_steps"] + r["cut_steps_saved"] for r in cut)
        out.append(f"| `search.cut_walks`: a trial's walk ends once it cannot reach its parent's F | no (fast "
                   f"preset) | {_frac(saved, total)} of the steps over {len(cut)} searches; {same} of {known} answers "
                   f"the documented full-walk ones bit for bit | `gaitmend reproduce recovery-speed --parts "
                   f"check,paper` |")
    ctl = by["control"]
    if ctl:
        cs, fs = (sum(r[k]["sim_steps"] for r in ctl) for k in ("cut", "full"))
        cw, fw = (sum(r[k]["wall_s"] for r in ctl) for k in ("cut", "full"))
        out.append(f"| `controls.cut_walks`: the random-search control's walk ends once it cannot beat the control's "
                   f"best so far | yes | {sum(r['identical'] for r in ctl)} of {len(ctl)} controls (30 x 60) the same "
                   f"best as with full walks, bit for bit; {cs:,} steps against {fs:,} ({fs / cs:.1f}x fewer), "
                   f"{cw:.0f} s against {fw:.0f} s in all | `gaitmend reproduce recovery-speed --parts control` |")
    if by["fast"] and by["paper"]:
        steps = statistics.median(r["sim_steps"] for r in by["fast"])
        paper = statistics.median(r["sim_steps"] + r["cut_steps_saved"] for r in by["paper"])
        out.append(f"| `stop.at_target` (fast preset): stop once the best meets the target, confirmed at half the "
                   f"step | no (fast preset) | median {steps:,.0f} steps to the target over {len(by['fast'])} runs "
                   f"against {paper:,.0f} for the paper's whole budget ({paper / steps:.0f}x fewer) | "
                   f"`gaitmend reproduce recovery-speed --parts fast` |")
    # F on the same seeds on both sides: the paper DE's runs here, else Table II's for the seed
    same = _equal_with_paper(rows, (1, 6), table2 or [])
    eq = [r for r in by["equal"] if r["lost_legs"] == [1, 6]]
    paper = [r for r in by["paper"] if r["lost_legs"] == [1, 6]]
    if paper and same:
        es = statistics.median(r["sim_steps"] for r in eq)
        ps = statistics.median(r["sim_steps"] + r["cut_steps_saved"] for r in paper)
        ef = statistics.median(r["fitness"] for r, _ in same)
        pf = statistics.median(f for _, f in same)
        out.append(f"| equal-quality configuration `{json.dumps(EQUAL)}` | no (a spec) | legs 1 & 6, {len(eq)} seeds: "
                   f"median {es:,.0f} steps against the paper DE's {ps:,.0f} ({ps / es:.1f}x fewer), median F "
                   f"{ef:.2f} against {pf:.2f} on the same {len(same)} seeds: "
                   f"{'equal' if ef >= pf else '**not** equal'} quality on the nominal model (other damages and the "
                   "perturbed robot below) | "
                   f"`gaitmend reproduce recovery-speed --parts equal,paper` |")
    return out + [""]

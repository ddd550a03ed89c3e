"""How a ``multigait`` result is shown: the cost with its units and direction, the CLI
table, bundle figures and file descriptions, replay styling, progress line."""

from __future__ import annotations

from pathlib import Path

from app.jobs.base import HeadlineRow, JobResult, ReplayTrack, Table, headline_row, table
from app.jobs.evidence import controls_of, robustness_of
from app.jobs.verdict import score, verdict_of

HISTORY_COLUMNS = {
    "generation": "0 = the initial swarm",
    "best": "best cost so far (coverage %: higher is better; distance mu: lower is better)",
    "mean": "mean cost of the gait sets evaluated in this generation",
    "generation_best": "best cost among the gait sets evaluated in this generation",
    "worst": "worst cost among the gait sets evaluated in this generation",
    "nodes_mean": "mean RRT-MP tree size of this generation",
    "evaluations": "gait sets evaluated so far",
    "at_bounds": "PSO: share of the swarm's coordinates on a wall of the box",
    "spread": "PSO: mean per-coordinate standard deviation of the swarm over the box width (uniform: 0.289)",
    "random_search_best": "the equal-budget random search's best cost so far (same generation size, evaluator and "
                          "planner draws; controls.random_search)",
    "random_search_mean": "the random search's mean cost in this generation",
}
# the convergence plot's series, the page's (history_axis, drawn by web/static/job.js) and the
# bundle's figure (plots.convergence): the search's, then its random-search control's
HISTORY_SERIES = {"best": "best so far", "generation_best": "best of generation", "mean": "mean of generation",
                  "worst": "worst of generation", "random_search_best": "random search (same budget): best so far",
                  "random_search_mean": "random search: mean of generation"}
TRACES = {
    "plan": "the plan from the root of the best tree, executed in full simulation gait after gait",
    "tree": "the best RRT-MP tree: node positions, parents, gaits and swept paths (not a time series)",
    "composition": "composed vs. fully simulated positions of replayed tree nodes (indexed by node, not time)",
}
FIGURES = {
    "convergence": "cost per generation (Tables I-II): the search's best so far, generation best, mean and worst, "
                   "beside the random search's best so far and generation mean at the same budget",
    "gait_traces": "the path of each evolved gait from the same start (Figs. 4, 5, 8)",
    "gait_distance_rotation": "distance and rotation per gait (Fig. 7)",
    "tree_map": "the best tree over the map, coloured by gait, with start, goal and plan (Figs. 6, 10)",
    "composition_error": "composed vs. simulated node positions of the best tree",
    "reuse": "the reuse experiment: distance and coverage per scenario (Tables III-IV)",
}


def damage_text(spec) -> str:
    stuck = spec.damage.stuck_modules or []
    return ("stuck modules " + ",".join(str(m) for m in stuck)) if stuck else "none"


def _unit(s: dict) -> tuple[str, str]:
    return ("%", "higher") if s["cost"] == "coverage" else ("mu", "lower")


def headline(s: dict) -> list[HeadlineRow]:
    r = s["result"]
    unit, better = _unit(s)
    label = "coverage of the map" if s["cost"] == "coverage" else "distance to the goal"
    rows = [headline_row(label, r["final_best"], unit, better),
            headline_row(f"{label} on held-out planner draws (mean)", r.get("heldout_mean"), unit, better)]
    ctl = {c.name: c for c in controls_of(s)}
    if "random_search" in ctl:
        rows.append(headline_row("random search, same budget: held-out mean",
                                 ctl["random_search"].metrics["heldout_mean"], unit, better))
    rob = robustness_of(s)
    if rob:
        rows.append(headline_row("robustness cases meeting the target", f"{rob.met} / {rob.total}", "", None,
                                 target=rob.target, met=rob.met == rob.total))
    rows += [headline_row(f"first generation best {s['cost']}", r["initial_best"], unit, better),
            headline_row("tree nodes", r["tree_nodes"], "", None),
            headline_row("tree to goal", r["goal_distance_mu"], "mu", "lower"),
            headline_row("re-planned cost matches the search", r["reproduced"], "", None)]
    return rows


COST_METRICS = {"in_sample": "in-sample", "in_sample_best": "best, in-sample", "heldout_mean": "held-out mean",
                "heldout_std": "held-out std", "heldout_min": "held-out min", "heldout_max": "held-out max",
                "change": "held-out minus in-sample", "first_generation_mean": "first generation mean",
                "last_generation_mean": "last generation mean", "search_minus_random_in_sample":
                "search minus random, in-sample", "search_minus_random_heldout": "search minus random, held out",
                "best": "best", "mean": "mean"}


def metric_names(s: dict) -> dict[str, tuple[str, str, float]]:
    """The controls' numbers are costs in the job's unit (coverage % or distance mu)."""
    unit = _unit(s)[0]
    return {**{k: (f"{s['cost']} {v}", unit, 1.0) for k, v in COST_METRICS.items()},
            "coverage_pct": ("coverage", "%", 1.0), "goal_distance_mu": ("tree to goal", "mu", 1.0),
            "gait_distance_mu": ("gait distance", "mu", 1.0)}


def verdict_scores(s: dict) -> list[dict]:
    """The held-out cost (fresh planner draws, never selected on) against the random search's
    at the same budget, with the spread of both over the same number of draws."""
    r = s["result"]
    unit, better = _unit(s)
    ctl = {c.name: c for c in controls_of(s)}
    n = ctl["heldout_rescoring"].evaluations if "heldout_rescoring" in ctl else None
    label = "held-out coverage" if s["cost"] == "coverage" else "held-out distance to the goal"
    return [score("heldout_mean", label, r.get("heldout_mean"), unit, better, controls=["random_search"],
                  std=r.get("heldout_std"), std_key="heldout_std", n=n, ddof0=True)]


def verdict(s: dict) -> dict:
    """The paper states no target of its own: the verdict is the comparison with the random
    search; the robustness cases are judged against a share of the nominal cost."""
    rows = headline(s)
    target = {"text": "none stated by the paper: the cost is judged against the random search at the same budget",
              "met": None}
    return verdict_of(s, rows, verdict_scores(s), target=target, primary=rows[0])


def summary_tables(s: dict) -> list[Table]:
    r = s["result"]
    stuck = s["damage"].get("stuck_modules") or "none"

    def g(v):
        return "-" if v is None else f"{v:.2f}"

    notes = [f"best tree: {r['tree_nodes']} nodes, {r['goal_distance_mu']:.2f} mu from the goal; "
             f"re-planned cost matches the search: {r['reproduced']}"]
    for name, sc in (s.get("reuse") or {}).items():
        notes.append(f"reuse {name}: distance {sc['distance_mu']['mean']:.2f} ({sc['distance_mu']['std']:.2f}) mu, "
                     f"coverage {sc['coverage_pct']['mean']:.1f} ({sc['coverage_pct']['std']:.1f}) %")
    title = f"{s['robot']}: {s['gaits']} gaits, cost {s['cost']} ({s['cost_units']}), stuck modules {stuck}"
    out = [table(title, ["cost", "first generation best", "first generation mean", "final best", "final mean"],
                 [[s["cost"], g(r["initial_best"]), g(r["initial_mean"]), g(r["final_best"]), g(r["final_mean"])]],
                 notes)]
    ctl = controls_of(s)
    if ctl:
        out.append(table("controls", ["control", "evaluations", "numbers", "note"],
                         [[c.label, c.evaluations,
                           ", ".join(f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}"
                                     for k, v in c.metrics.items()), c.note] for c in ctl]))
    rob = robustness_of(s)
    if rob:
        keys = list(rob.spread)
        out.append(table(f"robustness: {rob.met} of {rob.total} cases meet the target ({rob.target})",
                         ["case"] + keys + ["target met"],
                         [["nominal"] + [g(rob.spread[k]["nominal"]) for k in keys] + ["-"]] +
                         [[c.label] + [g(c.metrics.get(k)) for k in keys] + [str(c.target_met)]
                          for c in rob.cases]))
    if s.get("per_gait"):
        out.append(table("per gait", ["gait", "distance (mu)", "rotation (deg)"],
                         [[p["gait"], f"{p['distance_mu']:.2f}", f"{p['rotation_deg']:.1f}"] for p in s["per_gait"]]))
    return out


def page_tables(s: dict) -> list[Table]:
    """The job page's one table of the search: first against final generation. The CLI
    table's notes (tree size, re-planned cost, reuse) and its per-gait table are left out:
    the page shows them once each, in the headline, the reuse panel and the per-gait
    trials panel, never again as a raw line under a table."""
    first = summary_tables(s)[0]
    unit, better = _unit(s)
    note = f"{s['cost']} in {unit} ({s['cost_units']}; {better} is better)"
    return [table("Search: first and final generation", first["columns"][1:], [r[1:] for r in first["rows"]], [note])]


def history_axis(spec: dict) -> dict:
    """What the convergence plot draws, on the page and in the bundle's figure: the cost in its
    units and direction, the search's series and its random-search control's."""
    if spec.get("cost", "coverage") == "coverage":
        y, better = "coverage (% of map cells)", "higher"
    else:
        y, better = "distance to goal (mu)", "lower"
    return {"x": "generation", "x_note": HISTORY_COLUMNS.get("generation"), "y": y, "better": better,
            "series": dict(HISTORY_SERIES)}


def figures(result: JobResult, out: Path) -> list[Path]:
    from app.jobs.multigait import plots as P

    return P.all_plots(result, out, history_axis({"cost": result.summary["cost"]}))


def replay_style(names: list[str]) -> list[ReplayTrack]:
    """The replay plays the plan alone (one robot a software renderer draws smoothly; the
    gaits side by side dropped it to about 2 frames a second): each gait's own path is in
    the gait traces plot. Without a plan, the gaits."""
    if "plan" in names:
        return [ReplayTrack("plan", "the plan", "method", 0)]
    gaits = sorted((n for n in names if n.startswith("gait")), key=lambda n: int(n[4:]) if n[4:].isdigit() else 99)
    return [ReplayTrack(n, f"gait {n[4:]}", None, i + 1) for i, n in enumerate(gaits)]


def progress_text(info: dict) -> str:
    parts = [f"best {info['best']:.3g}"] if "best" in info else []
    if "sim_steps_per_s" in info:
        parts.append(f"{info['sim_steps_per_s'] / 1e3:.0f}k steps/s")
    if "evaluations" in info:
        parts.append(f"{info['evaluations']} evals")
    return "  ".join(parts)

"""How a ``repertoire`` result is shown: headline (coverage, QD-score, best against the
random control), CLI tables, bundle figures, history columns, progress line."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.jobs.base import HeadlineRow, JobResult, ReplayTrack, Table, headline_row, table
from app.jobs.evidence import controls_of

HISTORY_COLUMNS = {
    "iteration": "MAP-Elites iterations done (one batch of gaits each)",
    "evaluations": "MAP-Elites gaits scored so far (the random control has scored as many)",
    "elites": "gaits in the map",
    "coverage": "share of the archive's cells filled",
    "qd_score": "QD-score: sum over elites of (forward distance - archive.min_forward_m), m",
    "best": "best forward distance in the map, m (archive.min_forward_m while it is empty)",
    "fell": "gaits of this iteration's MAP-Elites batch that fell",
    "random_coverage": "the random-search control's coverage, same evaluations",
    "random_qd_score": "the random-search control's QD-score, m",
    "random_best": "the random-search control's best forward distance, m",
}
HISTORY_SERIES = {"qd_score": "MAP-Elites QD-score", "random_qd_score": "random search QD-score"}
TRACES = {"best": "the map's best gait (longest forward distance), one trial as simulated"}
FIGURES = {
    "progress": "coverage and QD-score against evaluations, MAP-Elites and the random-search control",
    "archive": "the map: every elite at its behaviour descriptor (2-D slices), coloured by forward distance",
}


def replay_style(names: list[str]) -> list[ReplayTrack]:
    """The best gait first (the replay opens on it), then each replayed elite by cell."""
    out = []
    for n in names:
        if n == "best":
            out.append(ReplayTrack("best", "the map's best gait", "method", 0))
        elif n.startswith("elite_") and n[6:].isdigit():
            out.append(ReplayTrack(n, f"elite of cell {int(n[6:])}", None, 1 + int(n[6:])))
    return out


def history_axis(spec: dict) -> dict:
    return {"x": "evaluations", "x_note": HISTORY_COLUMNS["evaluations"], "y": "QD-score (m)", "better": "higher",
            "series": dict(HISTORY_SERIES)}


def damage_text(spec) -> str:
    return spec.damage.describe(intact="none (intact)")


def _random(s: dict):
    return next((c for c in controls_of(s) if c.name == "random_search"), None)


def headline(s: dict) -> list[HeadlineRow]:
    a = s["archive"]
    rows = [
        headline_row("coverage", 100 * a["coverage"], "%", "higher"),
        headline_row("QD-score", a["qd_score"], "m", "higher"),
        headline_row("elites", a["elites"], "", "higher"),
        headline_row("best forward distance", a["best_forward_m"], "m", "higher"),
    ]
    r = _random(s)
    if r is not None:
        rows += [headline_row("random search coverage (same budget)", 100 * r.metrics["coverage"], "%", "higher"),
                 headline_row("random search QD-score (same budget)", r.metrics["qd_score"], "m", "higher"),
                 headline_row("random search best forward distance", r.metrics["best_forward_m"], "m", "higher")]
    c = s.get("timestep_check") or {}
    if c.get("elites"):
        rows.append(headline_row(f"best {c['elites']} elites at half the step: largest forward change",
                                 c["abs_diff_m"]["max"], "m", "lower"))
    return rows


def verdict_scores(s: dict) -> list[dict]:
    from app.jobs.verdict import score

    a = s["archive"]
    return [score("qd_score", "QD-score", a["qd_score"], "m", "higher"),
            score("coverage", "coverage", a["coverage"], "", "higher"),
            score("best_forward_m", "best forward distance", a["best_forward_m"], "m", "higher")]


def metric_names(s: dict) -> dict:
    return {"coverage": ("coverage", "%", 100.0), "qd_score": ("QD-score", "m", 1.0),
            "best_forward_m": ("best forward", "m", 1.0), "elites": ("elites", "", 1.0)}


def _f(v, fmt="{:.3f}") -> str:
    return "-" if v is None else fmt.format(v)


def summary_tables(s: dict) -> list[Table]:
    a, c, d = s["archive"], s["controller"], s["descriptor"]
    out = [table("Map", ["", "MAP-Elites", "random search"],
                 [[k, *v] for k, v in _map_rows(s)],
                 [f"{a['cells']} CVT cells over {d['type']} ({len(d['names'])}-D); QD-score offset "
                  f"{a['qd_offset_m']} m; {s['search']['evaluations']} gaits each"])]
    out.append(table("Controller", ["robot", "driven joints", "parameters", "period (s)", "amplitude", "offset"],
                     [[s["robot"]["name"], len(c["joints"]), c["parameters"], f"{c['period_s'][0]}-{c['period_s'][1]}",
                       c["amplitude"], c["offset"]]],
                     ["amplitude and offset: fractions of each joint's half range (app/jobs/repertoire/controller.py)"]))
    e = s["elites"]
    if e["cell"]:
        top = np.argsort(-np.asarray(e["objective"]), kind="stable")[:10]
        out.append(table("Best elites", ["cell", "forward (m)", "lateral (m)", "yaw (deg)", "energy (J)", "descriptor"],
                         [[e["cell"][i], _f(e["objective"][i]), _f(e["lateral_m"][i]), _f(e["yaw_deg"][i], "{:.1f}"),
                           _f(e["energy_j"][i], "{:.1f}"), " ".join(f"{v:.2f}" for v in e["measures"][i])]
                          for i in top]))
    t = s.get("timestep_check") or {}
    if t.get("elites"):
        out.append(table("Timestep check", ["elites", "step (s)", "half step (s)", "median |change| (m)",
                                            "max |change| (m)", "same cell", "fell at half step"],
                         [[t["elites"], t["timestep_s"], t["half_timestep_s"], _f(t["abs_diff_m"]["median"], "{:.4f}"),
                           _f(t["abs_diff_m"]["max"], "{:.4f}"), t["same_cell"], t["fell_at_half"]]]))
    return out


def page_tables(s: dict) -> list[Table]:
    """The CLI's tables the job page does not draw already (views.py: the map against the
    random control, the best elites)."""
    return [t for t in summary_tables(s) if t["title"] not in ("Map", "Best elites")]


def _map_rows(s: dict) -> list[tuple[str, list]]:
    a, r = s["archive"], _random(s)
    rm = r.metrics if r is not None else {}
    return [("coverage (%)", [_f(100 * a["coverage"], "{:.1f}"), _f(100 * rm["coverage"], "{:.1f}") if rm else "-"]),
            ("QD-score (m)", [_f(a["qd_score"], "{:.2f}"), _f(rm.get("qd_score"), "{:.2f}")]),
            ("elites", [str(a["elites"]), str(rm.get("elites", "-"))]),
            ("best forward (m)", [_f(a["best_forward_m"]), _f(rm.get("best_forward_m"))])]


def figures(result: JobResult, out: Path) -> list[Path]:
    from app.jobs.repertoire import plots

    return plots.progress(result.history, out) + plots.archive(result.summary, out)


def progress_text(info: dict) -> str:
    parts = [f"it {info['iteration']}"] if "iteration" in info else []
    if "coverage" in info:
        parts.append(f"coverage {100 * info['coverage']:.1f}%")
    if "qd_score" in info:
        parts.append(f"QD {info['qd_score']:.3g}")
    if "best_m" in info:
        parts.append(f"best {info['best_m']:.3f} m")
    return "  ".join(parts)

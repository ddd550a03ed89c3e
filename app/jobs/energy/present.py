"""How an ``energy`` result is shown: the cost of transport per stage, the residuals, the
gait and links as the headline; tables for the CLI and dashboard; figures; plotly views."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from app.core.colors import hex_color
from app.jobs.base import HeadlineRow, JobResult, ReplayTrack, Table, headline_row, table
from app.jobs.energy.spec import EPS_RATIO_MIN, walk_target
from app.jobs.evidence import controls_of, robustness_of
from app.jobs.verdict import score
from app.robots.quadruped import LEGS

HISTORY_COLUMNS = {
    "generation": "0 = the initial population",
    "evaluations": "GA fitness evaluations so far",
    "best": "best J (Eq. 11) so far; infeasible candidates carry a penalty >= 1e4",
    "generation_best": "best J in this generation",
    "mean": "mean J in this generation (penalties included)",
    "worst": "worst J in this generation",
    "feasible_share": "share of this generation that is periodic and reachable",
    "mean_feasible": "mean J of this generation's feasible candidates",
    "best_cot": "CoT (final stage) of the best so far",
    "random_search_best": "the equal-budget random search's best J so far (same generation size)",
    "random_search_generation_best": "the random search's best J in this generation",
    "random_search_feasible_share": "share of the random search's generation that is feasible",
}
TRACES = {
    "body": "trunk position and angles over one period on the NLP knots: the paper's NLP (first pass), the NLP "
            "re-solved with the legs' true wrench, forward with the first NLP's forces, final",
    "forces": "per QP sample: contact forces of the NLP (first pass and re-solved) and of the QP (FR, HR, FL, HL x "
              "xyz), their wrench on the trunk, the residual of the full equations per stage, final joint torques, "
              "stance mask",
    "physics": "the full-physics play-back: MuJoCo qpos per frame",
}
FIGURES = {
    "forces": "contact forces per leg and axis, NLP against final (Fig. 3)",
    "wrench": "the contacts' force and moment on the trunk and the residual of the full equations (Eq. 9)",
    "body_motion": "trunk motion over a period: NLP, NLP forces in the full equations, final (Fig. 4)",
    "gait_diagram": "contact phases of the four legs over two periods",
    "convergence": "J per generation (log scale): the GA's best so far and best of each generation, the random "
                   "search's best so far at the same budget",
    "residuals": "RMS residual per axis and stage (log scale)",
    "physics": "trunk drift and height in the MuJoCo play-back",
}


def _f(v, fmt="{:.3g}"):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)):
        return fmt.format(v)
    return str(v)


def history_axis(spec: dict) -> dict:
    """What the convergence plot draws, on the page and in the bundle's figure (plots.convergence)."""
    return {"x": "generation", "x_note": HISTORY_COLUMNS["generation"], "y": "J (Eq. 11)", "better": "lower",
            "series": {"best": "GA: best so far", "generation_best": "GA: best of the generation",
                       "random_search_best": "random search (same budget): best so far"}}


def damage_text(spec) -> str:
    t = spec.task
    return f"V {t.speed_m_s:g} m/s, h {t.height_m:g} m, step {t.swing_height_m:g} m, {spec.gait.family}"


def headline(s: dict) -> list[HeadlineRow]:
    rows = [headline_row("feasible (periodic, reachable)", bool(s.get("feasible")), "", None, "periodic within "
                         "tolerance", bool(s.get("feasible")))]
    cot = s.get("cot")
    if cot:
        rows.append(headline_row("CoT final (Eq. 11)", cot["final"], "", "lower"))
        rows.append(headline_row("CoT in MuJoCo physics", cot.get("physics"), "", "lower"))
        rows.append(headline_row("J = CoT + w x jerk (Eq. 11)", s["J"], "", "lower"))
        ratio = s.get("eps_ratio_nlp_over_qp")
        rows.append(headline_row("eps_NLP / eps_QP", ratio, "x", "higher", f">= {EPS_RATIO_MIN:g}",
                                 None if ratio is None else ratio >= EPS_RATIO_MIN))
        w = s.get("periodicity_error")
        rows.append(headline_row("periodicity error w", w, "", "lower", "<= 1", None if w is None else w <= 1.0))
    g = s["gait"]
    rows.append(headline_row("period T", g["period_s"], "s", None))
    rows.append(headline_row("links hip / thigh / calf", " / ".join(f"{v:.3f}" for v in s["links_m"]), "m", None))
    ph = s.get("physics")
    if ph:  # judged by the run (ph["target_met"]); the period count its text names is the robustness block's
        rob = robustness_of(s)
        text = rob.target if rob is not None and rob.target else walk_target(s["task"]["speed_m_s"]).text
        rows.append(headline_row(f"walks {ph['periods_completed']} periods in MuJoCo", ph["stays_up"], "", "higher",
                                 text, ph["target_met"]))
        rows.append(headline_row("realised speed", ph["speed_m_s"], "m/s", None))
    return rows


# the GA's J against the controls that computed the same J on the same robot and task
J_CONTROLS = ("random_search", "paper_table1", "no_residual_iteration")
METRIC_NAMES = {"J": ("J (Eq. 11)", "", 1.0), "ga_J": ("the GA's J", "", 1.0), "feasible": ("feasible", "", 1.0),
                "cot_final": ("CoT final", "", 1.0), "cot_nlp_first": ("CoT, NLP first pass", "", 1.0),
                "cot_nlp": ("CoT, NLP", "", 1.0), "cot_qp": ("CoT, QP", "", 1.0), "cot_massless": ("CoT, massless legs", "", 1.0),
                "eps_nlp_N": ("residual NLP", "N", 1.0), "eps_qp_N": ("residual QP", "N", 1.0),
                "eps_nlp_legs_N": ("residual NLP with legs", "N", 1.0), "eps_ratio": ("eps_NLP / eps_QP", "x", 1.0),
                "periodicity_error": ("periodicity error w", "", 1.0), "ga_better": ("GA better", "", 1.0),
                "stays_up": ("stays up", "", 1.0), "speed_m_s": ("speed", "m/s", 1.0), "mean_height_m": ("height", "m", 1.0),
                "cot": ("CoT", "", 1.0), "periods_completed": ("periods", "", 1.0),
                "drift_angle_rad": ("drift angle", "deg", 57.29577951308232)}


def metric_names(s: dict) -> dict[str, tuple[str, str, float]]:
    return METRIC_NAMES


def verdict_scores(s: dict) -> list[dict]:
    """J = CoT + w x jerk (Eq. 11, lower is better), the number the GA minimises, against
    the controls that computed the same J (the random search, the paper's Table 1 gait,
    the single NLP pass) and found a feasible gait; the other controls are ablations
    judged on their own terms."""
    return [score("J", "J (Eq. 11)", s.get("J") if s.get("feasible") else None, "", "lower", controls=J_CONTROLS,
                  only_if="feasible")]  # an infeasible control's J is a penalty (>= 1e4), not a cost


def summary_tables(s: dict) -> list[Table]:
    g = s["gait"]
    out = [table("Gait and design", ["leg", "touchdown t_i (s)", "duty beta_i"],
                 [[leg, _f(t, "{:.4f}"), _f(b, "{:.3f}")] for leg, t, b in zip(g["legs"], g["touchdown_s"], g["duty"])],
                 [f"T = {g['period_s']:.4f} s; links hip/thigh/calf = "
                  + ", ".join(f"{v:.4f}" for v in s["links_m"]) + " m; link masses "
                  + ", ".join(f"{v:.3f}" for v in s["link_masses_kg"]) + f" kg; total {s['total_mass_kg']:.2f} kg; "
                  f"inertias: {s['inertia']}"])]
    cot = s.get("cot")
    if cot:
        ph = s.get("physics") or {}
        out.append(table("Cost of transport per stage", ["NLP (paper, first pass)", "NLP re-solved", "QP", "final",
                                                          "physics"],
                         [[_f(cot.get("nlp_first"), "{:.4f}"), _f(cot["nlp"], "{:.4f}"), _f(cot["qp"], "{:.4f}"),
                           _f(cot["final"], "{:.4f}"), _f(cot.get("physics"), "{:.4f}")]],
                         [f"J = {s['J']:.4f} = CoT {s['objective']['cot']:.4f} + {s['objective']['jerk_weight_s']:g} s x "
                          f"{s['objective']['jerk_term_N_s']:.1f} N/s (mean force rate)",
                          f"physics: feedback share of the work {_f(ph.get('feedback_cot_share'), '{:.1%}')}"]))
        axes = ("x", "y", "z", "roll", "pitch", "yaw", "norm")
        out.append(table("Residual of the full equations, RMS per axis (N; N m)", ["stage", *axes],
                         [[st, *[_f(s["eps"][st][a], "{:.3g}") for a in axes]] for st in s["eps"]],
                         [f"eps_NLP / eps_QP = {s['eps_ratio_nlp_over_qp']:.0f}; periodicity error w = "
                          f"{s['periodicity_error']:.3f} (forward check, 1 = tolerance); with the NLP's forces "
                          f"instead: {_f(s.get('nlp_forward_periodicity_error'), '{:.3f}')}"]))
    for key, title in (("physics", "Full-physics play-back"), ("physics_other_feedback", "Play-back, the control")):
        ph = s.get(key)
        if ph:
            d = ph.get("drift_per_period") or {}
            out.append(table(f"{title}: {ph.get('feedback', '')}",
                             ["stays up", "periods", "speed (m/s)", "height (m)", "CoT", "feedback share",
                              "drift pos (m)", "drift angle (rad)"],
                             [[_f(ph["stays_up"]), ph["periods_completed"], _f(ph["speed_m_s"], "{:.3f}"),
                               _f(ph["mean_height_m"], "{:.3f}"), _f(ph["cot"], "{:.4f}"),
                               _f(ph.get("feedback_cot_share"), "{:.1%}"), _f(d.get("pos_m"), "{:.4f}"),
                               _f(d.get("angle_rad"), "{:.4f}")]]))
    controls = controls_of(s)
    if controls:
        out.append(table("Controls", ["control", "evaluations", "metrics", "target met"],
                         [[c.label, c.evaluations, ", ".join(f"{k} {_f(v)}" for k, v in c.metrics.items()),
                           _f(c.target_met)] for c in controls],
                         [c.name + ": " + c.note for c in controls]))
    rob = robustness_of(s)
    if rob is not None:
        out.append(table(f"Robustness: {rob.target} ({rob.met}/{rob.total})",
                         ["case", "stays up", "speed (m/s)", "height (m)", "CoT", "met"],
                         [[c.label, _f(c.metrics["stays_up"]), _f(c.metrics["speed_m_s"], "{:.3f}"),
                           _f(c.metrics["mean_height_m"], "{:.3f}"), _f(c.metrics["cot"], "{:.4f}"),
                           _f(c.target_met)] for c in rob.cases]))
    return out


def figures(result: JobResult, out_dir: Path) -> list[Path]:
    from app.jobs.energy.plots import all_plots

    return all_plots(result, Path(out_dir), history_axis({}))  # the convergence figure draws the page's plot


def replay_style(trace_names: list[str]) -> list[ReplayTrack]:
    return [ReplayTrack(n, "the gait in MuJoCo physics" if n == "physics" else n, "method", i)
            for i, n in enumerate(trace_names)]


def progress_text(info: dict[str, Any]) -> str:
    if info.get("phase") in ("ga", "random_search"):
        return f"{info['phase']} gen {info['generation']}  best J {info['best_J']:.4g}  feasible {info['feasible_share']:.0%}"
    return "  ".join(f"{k} {v}" for k, v in info.items() if isinstance(v, (str, int, bool)))[:80]


def views(summary: dict, traces: dict[str, dict[str, Any]]) -> list[dict]:
    """Plotly figure dicts: forces (Fig. 3), trunk motion (Fig. 4), residuals, gait diagram."""
    out = []
    f = traces.get("forces")
    if f is not None and "f_qp" in f:
        t = np.asarray(f["time_s"]).tolist()
        fn, fq = np.asarray(f["f_nlp"]), np.asarray(f["f_qp"])
        data = []
        for i, leg in enumerate(LEGS):
            data.append({"type": "scatter", "x": t, "y": fq[:, 3 * i + 2].tolist(), "name": f"{leg} F_z final",
                         "line": {"color": hex_color(None, i)}})
            data.append({"type": "scatter", "x": t, "y": fn[:, 3 * i + 2].tolist(), "name": f"{leg} F_z NLP",
                         "line": {"color": hex_color(None, i), "dash": "dash"}})
        out.append(_panel("forces", "Normal contact forces (Fig. 3)",
                          "Per leg over one period: the paper's NLP (SRB + dummy legs, dashed) and the final QP forces "
                          "(solid), which satisfy the full multibody equations.",
                          {"data": data, "layout": {"xaxis": {"title": {"text": "t (s)"}},
                                                    "yaxis": {"title": {"text": "F_z (N)"}}}}))
    b = traces.get("body")
    if b is not None and "nlp_r" in b:
        t = np.asarray(b["time_s"]).tolist()
        data = []
        for key, role, label in (("nlp", "baseline", "NLP"), ("forward_nlp", "reference", "NLP forces, full equations"),
                                 ("final", "method", "final")):
            data.append({"type": "scatter", "x": t, "y": np.asarray(b[f"{key}_r"])[:, 2].tolist(), "name": f"z {label}",
                         "line": {"color": hex_color(role)}})
            data.append({"type": "scatter", "x": t, "y": np.asarray(b[f"{key}_theta"])[:, 1].tolist(),
                         "name": f"pitch {label}", "yaxis": "y2", "line": {"color": hex_color(role), "dash": "dot"}})
        out.append(_panel("body", "Trunk height and pitch over a period (Fig. 4)",
                          "The NLP's trunk path, the full equations integrated with the NLP's forces (they drift: the "
                          "residual), and with the final QP forces (periodic within tolerance).",
                          {"data": data, "layout": {"xaxis": {"title": {"text": "t (s)"}},
                                                    "yaxis": {"title": {"text": "z (m)"}},
                                                    # room for the right axis's title (it was clipped)
                                                    "yaxis2": {"title": {"text": "pitch (rad)"}, "overlaying": "y",
                                                               "side": "right", "automargin": True},
                                                    "margin": {"l": 56, "r": 64, "t": 36, "b": 44}}}))
    eps = summary.get("eps")
    if eps:
        axes = ["x", "y", "z", "roll", "pitch", "yaw"]
        out.append(_panel("residuals", "Residual of the full equations per stage (Eq. 9)",
                          "RMS over the period, per trunk axis: the paper's NLP, the NLP re-solved with the legs' true "
                          "wrench, the QP, and the forward check's final path.",
                          {"data": [{"type": "bar", "x": axes, "y": [eps[st][a] for a in axes], "name": st,
                                     "marker": {"color": hex_color(None, i)}} for i, st in enumerate(eps)],
                           "layout": {"barmode": "group", "yaxis": {"type": "log", "title": {"text": "N, N m"}}}}))
    g = summary.get("gait")
    if g:
        T = g["period_s"]
        data = []
        for i, leg in enumerate(g["legs"]):
            t0, dur = g["touchdown_s"][i], g["duty"][i] * T
            for start in (t0 - T, t0, t0 + T):
                a, e = max(start, 0.0), min(start + dur, 2 * T)
                if e > a:
                    data.append({"type": "bar", "orientation": "h", "y": [leg], "x": [e - a], "base": [a],
                                 "showlegend": False, "marker": {"color": hex_color("support")}})
        out.append(_panel("gait", f"Gait diagram (T = {T:.3f} s)", "Contact phases (bars) of the four legs over two periods.",
                          {"data": data, "layout": {"barmode": "overlay",
                                                    "xaxis": {"title": {"text": "t (s)"}, "range": [0, 2 * T]},
                                                    "yaxis": {"autorange": "reversed"}}}))
    return out


def _panel(pid: str, title: str, caption: str, figure: dict) -> dict:
    from app.jobs import viewkit as kit

    return kit.panel(pid, title, caption, figure=figure)

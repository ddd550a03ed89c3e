"""How a ``tipping`` result is shown: the chosen leg, foothold, time to tip and margins as
the headline, the per-run CLI table, bundle figures and file descriptions, replay styling."""

from __future__ import annotations

import json
from pathlib import Path

from app.jobs.base import HeadlineRow, JobResult, ReplayTrack, Table, headline_row, table
from app.jobs.evidence import CaseResult, ControlRow, controls_of, robustness_of
from app.jobs.tipping.evidence import target_of
from app.jobs.tipping.views import RUN_TRACKS  # the runs' names and colours, as the page and the figures draw them
from app.jobs.verdict import score

HISTORY_COLUMNS = {
    "run": "simulation index (0 = without recovery, 1 = with recovery; sweep runs follow)",
    "name": "which run",
    "tipped": "1 if the robot tipped over",
    "min_margin_deg": "smallest FASM margin after the first second (deg)",
    "downhill_deg": "sweep: downhill direction of the platform (0 = robot front down, 90 = left side)",
    "stance": "sweep: the tripod in stance",
    "recovery": "sweep: 1 if the recovery controller was on",
    "tipped_at_s": "sweep: when it tipped over (s), empty if it did not",
    "static_tip_deg": "sweep: platform tilt at which the stance polygon stops holding the robot statically (deg)",
    "detect_time_s": "sweep: when the judgment flagged tipping (s)",
    "edge": "sweep: the tipping edge (pair of legs)",
    "leg": "sweep: the adjustment leg (0: none)",
    "margin_after_deg": "sweep: FASM margin after the caught leg landed (deg)",
    "final_margin_deg": "sweep: FASM margin at the end of the run (deg)",
    "sim_steps": "sweep: physics steps of the run",
}
TRACES = {"recovery": "the run with tipping recovery on",
          "no_recovery": "the same scenario with recovery off (the control)"}
FIGURES = {
    "margin_timeline": "FASM stability margin against time with the threshold, detection and landing marked, each run's "
                       "line ending at a cross where it tipped over, clipped to [-45, 90] deg (Fig. 6); beneath it SSM "
                       "and NESM (on the job page behind their legend entries: a figure cannot hide them until "
                       "clicked) and the critical support edge; otherwise the job page's margin plot",
    "foot_forces": "foot normal forces per leg against time (legs 4-6 dashed), dotted: the QP's force for the foot "
                   "while it runs (the job page's force plot)",
    "tilt": "body tilt relative to the ground (clipped to +-90 deg) and the platform's tilt against time (the job "
            "page's tilt plot)",
    "sweep_success": "recovery success rate per downhill direction (polar)",
}


def damage_text(spec) -> str:
    scenario = spec.scenario.model_dump()
    if scenario.get("type") == "tilt":
        d = scenario.get("downhill_deg")  # else the paper's naming, y ccw when nothing is given
        where = f"downhill {d:g} deg" if d is not None else \
            f"{scenario.get('axis') or 'y'} {scenario.get('direction') or 'ccw'}"
        return f"tilt {where}, stance {''.join(map(str, scenario.get('stance', [])))}"
    return f"cliff on the {scenario.get('side', '?')}"


def headline(s: dict) -> list[HeadlineRow]:
    runs = s.get("runs", {})
    base = runs.get("no_recovery", {})
    rows = [headline_row("tips without recovery", bool(base.get("tipped")), "", None)]
    if "recovery" in runs:
        rec = runs["recovery"]
        target = target_of(s)
        rows += [headline_row("stays upright with recovery", not rec["tipped"], "", "higher"),
                 headline_row("recovery meets the target", target.met(rec), "", None, target.text, target.met(rec)),
                 headline_row("adjustment leg", s.get("adjustment_leg"), "", None),
                 headline_row("foothold (body frame)", s.get("foothold_body_m"), "m", None),
                 headline_row("detected at", s.get("detection_time_s"), "s", None),
                 headline_row("time to tip (Eq. 15)", s.get("time_to_tip_s"), "s", None),
                 headline_row("margin before landing", s.get("margin_before_landing_deg"), "deg", "higher"),
                 headline_row("margin after landing", s.get("margin_after_landing_deg"), "deg", "higher",
                              f">= {s['threshold_deg']:g} deg (threshold)",
                              None if s.get("margin_after_landing_deg") is None
                              else s["margin_after_landing_deg"] >= s["threshold_deg"])]
    band = s.get("band")
    if band:
        w, wo = band["with_recovery"], band["without_recovery"]
        rows += [headline_row("largest final tilt survived with recovery", w["max_upright_deg"], "deg", "higher"),
                 headline_row("largest final tilt survived without recovery", wo["max_upright_deg"], "deg", None),
                 headline_row("survivable tilt gained by recovery", band.get("gain_deg"), "deg", "higher", "> 0",
                              None if band.get("gain_deg") is None else band["gain_deg"] > 0)]
    rob = robustness_of(s)
    if rob:
        rows.append(headline_row("robustness: perturbed re-runs meeting the target", f"{rob.met}/{rob.total}", "",
                                 None, rob.target, rob.met == rob.total))
    if s.get("sweep"):
        rows.append(headline_row("sweep success rate", s["sweep"].get("overall_success_rate"), "", "higher"))
    return rows


def _num(v, fmt="{:.2f}") -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    return fmt.format(v) if isinstance(v, float) else str(v)


EVIDENCE_COLUMNS = (("tipped", "tipped"), ("margin_after_landing_deg", "margin after landing (deg)"),
                    ("detection_time_s", "detected (s)"), ("time_to_tip_s", "Eq. 15 t_s (s)"), ("swing_s", "swing (s)"),
                    ("final_margin_deg", "final margin (deg)"), ("max_slip_m", "foot slip (m)"),
                    ("friction_demand", "friction demand"))


def _evidence_row(c: ControlRow | CaseResult) -> list[str]:
    return [c.name] + [_num(c.metrics.get(k)) for k, _ in EVIDENCE_COLUMNS] + [_num(c.target_met)]


def metric_names(s: dict) -> dict[str, tuple[str, str, float]]:
    return {k: (h.split(" (")[0], h[h.index("(") + 1:-1] if "(" in h else "", 1.0) for k, h in EVIDENCE_COLUMNS} | {
        "tipped": ("tipped over", "", 1.0), "tipped_at_s": ("tipped at", "s", 1.0), "leg": ("adjustment leg", "", 1.0),
        "adjustment_time_s": ("adjustment", "s", 1.0), "detection_time_s": ("detected", "s", 1.0)}


def verdict_scores(s: dict) -> list[dict]:
    """Staying upright first (the recovery's point), then the margin after the caught leg
    landed (how safely)."""
    rec = (s.get("runs") or {}).get("recovery")
    if rec is None:
        return []
    return [score("tipped", "tipped over", bool(rec.get("tipped")), "", "lower"),
            score("margin_after_landing_deg", "margin after landing", s.get("margin_after_landing_deg"), "deg", "higher")]


def evidence_tables(s: dict) -> list[Table]:
    out = []
    heads = ["run"] + [h for _, h in EVIDENCE_COLUMNS] + ["target met"]
    controls = controls_of(s)
    if controls:
        out.append(table(f"controls: the same scenario with parts of the method switched off; target: "
                         f"{target_of(s).text}", heads,
                         [_evidence_row(c) for c in controls], [f"{c.name}: {c.label}" for c in controls]))
    rob = robustness_of(s)
    if rob:
        out.append(table(f"robustness: the recovery re-simulated; target: {rob.target}", heads,
                         [_evidence_row(c) for c in rob.cases], [f"{rob.met} of {rob.total} meet the target"]))
    band = s.get("band")
    if band:
        out.append(table(f"survivable final tilt (bisection to {band['tolerance_deg']:g} deg on real runs)",
                         ["controller", "largest upright (deg)", "smallest tipped (deg)", "probes"],
                         [[name, _num(b["max_upright_deg"], "{:.1f}"), _num(b["min_tipped_deg"], "{:.1f}"),
                           b["evaluations"]] for name, b in (("with recovery", band["with_recovery"]),
                                                              ("without recovery", band["without_recovery"]))],
                         [b["note"] for b in (band["with_recovery"], band["without_recovery"]) if b["note"]]))
    return out


def summary_tables(s: dict) -> list[Table]:
    rows = []
    for name, r in s.get("runs", {}).items():
        def f(k, fmt="{:.2f}"):
            v = r.get(k)
            return "-" if v is None else fmt.format(v) if isinstance(v, float) else str(v)
        margins = "-" if r.get("margin_before_landing_deg") is None else \
            f"{r['margin_before_landing_deg']:.1f} / {r['margin_after_landing_deg']:.1f}"
        rows.append([name, f("tipped_at_s") if r.get("tipped") else "no", f("first_below_threshold_s"),
                     f("detection_time_s"), f("tipping_edge"), f("adjustment_leg"), f("adjustment_time_s"),
                     margins, f("final_body_tilt_deg", "{:.1f}")])
    out = [table(f"{s['robot']}: {s['scenario']['type']} scenario, threshold {s['threshold_deg']} deg",
                 ["run", "tipped (s)", "below threshold (s)", "detected (s)", "edge", "leg", "adjust (s)",
                  "margin before/after (deg)", "final tilt (deg)"], rows)]
    sw = s.get("sweep")
    if sw:
        out.append(table("sweep: per downhill direction", ["downhill (deg)", "success rate", "tips without recovery",
                                                           "recovered by the controller"],
                         [[f"{d:g}", _rate(a), _rate(b), _rate(c)] for d, a, b, c in
                          zip(sw["directions_deg"], sw["success_rate"], sw["tip_rate_without_recovery"],
                              sw["recovered_rate"])],
                         [f"overall success rate: {_rate(sw.get('overall_success_rate'))}"]))
    return out + evidence_tables(s)


def _rate(v) -> str:
    return "-" if v is None else f"{100 * v:.0f}%"


def figures(result: JobResult, out: Path) -> list[Path]:
    from app.jobs.tipping import plots as P

    files = P.margin_timeline(result.traces, result.summary, out)
    files += P.foot_forces(result.traces, out)
    files += P.tilt(result.traces, out)
    if "sweep" in result.summary:
        files += P.sweep(result.summary["sweep"], out)
    return files


def replay_style(names: list[str]) -> list[ReplayTrack]:
    known = {n: ReplayTrack(n, label, role, order) for n, (label, role, order) in RUN_TRACKS.items()}
    return [known.get(n, ReplayTrack(n, n, None, 2 + i)) for i, n in enumerate(names)]


def progress_text(info: dict) -> str:
    return "  ".join(f"{k} {json.dumps(v) if not isinstance(v, float) else f'{v:.3g}'}" for k, v in info.items())[:80]

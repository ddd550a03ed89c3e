"""How a ``freegait`` result is shown: footholds in zones, route finished, SM and K_R as the
headline; per-run tables (the walk, its controls); bundle figures (the minefield top view
as Fig. 9, SM and K_R against time as Fig. 8b-c, the support/transfer diagram as Fig. 8a)."""

from __future__ import annotations

from pathlib import Path

from app.jobs.base import HeadlineRow, JobResult, ReplayTrack, Table, headline_row, table
from app.jobs.evidence import controls_of, robustness_of
from app.jobs.freegait.spec import TARGET, target_parts
from app.jobs.verdict import score

HISTORY_COLUMNS = {
    "transfer": "transfer number, from 0",
    "tripod": "the tripod transferred (1 = legs 1, 4, 5; 2 = legs 2, 3, 6)",
    "t_lift": "time the tripod lifted (s)",
    "t_search": "time of the foothold search, at the end of subphase 1 (s)",
    "stopped": "1 if no tripod was valid with the body moving, so the body stopped for this transfer",
    "ev": "Ev = K + k_ev SM_t of the chosen tripod (Eq. 24), m",
    "k": "K of the chosen tripod (Eq. 14), m",
    "sm_t": "SM_t of the chosen tripod (Eq. 5), m",
    "l": "L of the chosen tripod (Eq. 4), m",
    "r_t2": "R_T2 of the chosen tripod (Eq. 11), m",
    "valid": "number of valid tripods among the N^3",
    "t_sub3": "start of subphase 3 (s)",
    "t_touchdown": "all three feet in contact (s)",
    "transfer_s": "transfer duration (s)",
    "failed_legs": "feet that missed the ground in subphase 3 (the foothold became forbidden)",
    "support_s": "duration of this tripod's support phase before the lift (s)",
}
TRACES = {"walk": "the planner's walk (per 0.1 s control period: pose, leg phases, SM, K_R, stops, joint state)",
          "unaware": "the same route with the forbidden zones ignored (control, Fig. 9a)",
          "aware": "the same route with the forbidden zones known (control)"}
FIGURES = {
    "minefield": "top view: footholds over the forbidden zones and safe areas (Fig. 9), the walk and its control "
                 "(zones ignored) each in its own panel (the job page draws both on one map, the control behind "
                 "its legend entries); names and colours as on the page",
    "margins": "stability margin SM with SM_min and robot kinematic margin K_R against time, body stops shaded "
               "(Fig. 8b-c; the job page's margins plot)",
    "gait_diagram": "support (bar) and transfer of each leg against time, tripod 1 blue, tripod 2 orange (Fig. 8a)",
}
PHASE_NAMES = ("support", "subphase 1", "subphase 2", "subphase 3")


def damage_text(spec) -> str:
    r, f = spec.route, spec.forbidden
    turn = f", {r.turn_rate_deg_s:g} deg/s" if r.gait != "crab" else ""
    return (f"{r.gait} {r.crab_angle_deg:g} deg{turn}; {f.density_per_m2:g} zones/m2 "
            f"({'known' if f.known else 'unknown'}), ground {spec.terrain.roughness_m:g} m")


def headline(s: dict) -> list[HeadlineRow]:
    sm_min = s.get("sm_min_m", 0.05)
    met = target_parts(s, sm_min)  # the target's parts, each beside its value
    rows = [
        headline_row("footholds in forbidden zones", s.get("footholds_in_zones"), "", "lower", "0", met["no_zone_footholds"]),
        headline_row("route finished", bool(s.get("finished")), "", "higher", "finishes", met["finished"]),
        headline_row("minimum stability margin SM", s.get("min_sm_m"), "m", "higher", f"> SM_min = {sm_min:g} m",
                     met["sm_above_min"]),
        headline_row("minimum kinematic margin K_R", s.get("min_k_r_m"), "m", "higher"),
        headline_row("body stopped", s.get("stop_time_s"), "s", "lower"),
        headline_row("mean speed", s.get("mean_speed_m_s"), "m/s", "higher"),
        headline_row("tracking error (max)", s.get("tracking_error_max_m"), "m", "lower"),
        headline_row("footholds / transfers", f"{s.get('footholds')} / {s.get('transfers')}", ""),
    ]
    ctl = {c.name: c for c in controls_of(s)}
    if "unaware" in ctl:
        rows.append(headline_row("footholds in zones, zones ignored (control)", ctl["unaware"].metrics["footholds_in_zones"],
                                 "", None))
    return rows


METRIC_NAMES = {"finished": ("finished", "", 1.0), "footholds_in_zones": ("footholds in zones", "", 1.0),
                "footholds_in_safe_areas": ("footholds in safe areas", "", 1.0),
                "closest_zone_m": ("closest zone centre", "cm", 100.0), "min_sm_m": ("minimum SM", "cm", 100.0),
                "min_k_r_m": ("minimum K_R", "cm", 100.0), "stop_time_s": ("body stopped", "s", 1.0),
                "mean_speed_m_s": ("mean speed", "cm/s", 100.0), "tracking_error_max_m": ("tracking error", "cm", 100.0),
                "foothold_error_max_m": ("foothold error", "cm", 100.0), "transfers": ("transfers", "", 1.0),
                "failed_touchdowns": ("failed touchdowns", "", 1.0), "time_s": ("walk time", "s", 1.0)}


def metric_names(s: dict) -> dict[str, tuple[str, str, float]]:
    return METRIC_NAMES


def verdict_scores(s: dict) -> list[dict]:
    """Footholds in forbidden zones first (the planner's point), then finishing the route,
    then the smallest stability margin on the way."""
    return [score("footholds_in_zones", "footholds in forbidden zones", s.get("footholds_in_zones"), "", "lower"),
            score("finished", "finished the route", bool(s.get("finished")), "", "higher"),
            score("min_sm_m", "minimum stability margin SM", None if s.get("min_sm_m") is None else 100 * s["min_sm_m"],
                  "cm", "higher", scale=100.0)]


def _fmt(v):
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return round(v, 4)
    return v


def summary_tables(s: dict) -> list[Table]:
    cols = ["run", "finished", "in zones", "min SM m", "stopped s", "speed m/s", "track m", "target"]

    def row(name, m, met):
        return [name, _fmt(m["finished"]), m["footholds_in_zones"], _fmt(None if m["min_sm_m"] is None else round(m["min_sm_m"], 3)),
                _fmt(round(m["stop_time_s"], 1)), _fmt(round(m["mean_speed_m_s"], 4)),
                _fmt(round(m["tracking_error_max_m"], 3)), _fmt(met)]

    controls = controls_of(s)
    rows = [row("walk", s, s.get("target_met"))]
    rows += [row(c.name, c.metrics, c.target_met) for c in controls]
    notes = [f"target: {TARGET.text}",
             f"field: {s['field']['zones']} zones ({s['field']['density_per_m2']:g}/m2), ground "
             f"{s['field']['roughness_m']:g} m peak to valley; walk: {s.get('footholds')} footholds, "
             f"{s.get('footholds_in_safe_areas')} in safe areas (closest zone centre {_fmt(s.get('closest_zone_m'))} m), "
             f"{s.get('transfers')} transfers, min K_R {_fmt(s.get('min_k_r_m'))} m, touchdowns within "
             f"{_fmt(s.get('foothold_error_max_m'))} m of the planned footholds"]
    notes += [f"{c.name}: {c.label}" for c in controls]
    out = [table("Walk and controls on the same field", cols, rows, notes)]
    rb = robustness_of(s)
    if rb is not None:
        out.append(table(f"Robustness ({rb.met}/{rb.total} meet the target)", cols,
                         [row(c.name, c.metrics, c.target_met) for c in rb.cases], [rb.target]))
    causes = {k: v for k, v in (s.get("stop_time_by_cause_s") or {}).items() if v}
    if causes:
        out.append(table("Body stops by cause (s)", list(causes), [[_fmt(v) for v in causes.values()]],
                         ["stability: SM <= SM_min; kinematic: K <= 0; touchdown_failed: a foot missed the ground; "
                          "no_valid_tripod_at_speed: the search needed the body stopped; no_valid_tripod: none at all"]))
    return out


def progress_text(info: dict) -> str:
    sm = info.get("min_sm_m")
    return (f"{info.get('run', '')}: finished {info.get('finished')}, in zones {info.get('in_zones')}, "
            f"min SM {'-' if sm is None else f'{sm:.3f}'} m")[:80]


def replay_style(trace_names: list[str]) -> list[ReplayTrack]:
    out = []
    for n in trace_names:
        if n == "walk":
            out.append(ReplayTrack(n, "free gait (zones known)", "method", 0))
        else:
            out.append(ReplayTrack(n, TRACES.get(n, n).split("(")[0].strip(), "control", 1))
    return out


def figures(result: JobResult, out: Path) -> list[Path]:
    from app.jobs.freegait import plots as P  # matplotlib only when drawing (the CLI starts faster)

    s, tr = result.summary, result.traces
    files = P.minefield_figure(s, tr, out)
    files += P.margins_figure(s, tr, out)
    files += P.gait_diagram_figure(tr, out)
    return files

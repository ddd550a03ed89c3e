"""Dashboard views of the tipping kind (paper 002): the FASM margin against time with the
threshold, detection and landing marked, with and without recovery (SSM and NESM one click
away in the legend), the critical support edge beneath it; foot normal forces per leg (with
the QP's); body and platform tilt; the direction sweep as a polar success rate; the
adjustments and runs as tables. Legs are numbered as in the paper, from 1.

The margin, force and tilt plots are described once here (``margin_runs``,
``margin_events``, ``force_runs``, ``tilt_lines`` and the titles and colours beside them):
the page's panels and the bundle's figures (app/jobs/tipping/plots.py) both draw from these,
so a referee reading the zip sees what the job page shows (issue 25)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.core.colors import ROLES, hex_color
from app.jobs import viewkit as kit
from app.jobs.tipping.evidence import target_of
from app.jobs.tipping.scenario import edge_name

# the two runs of a scenario: trace name -> (label, colour role, replay order); the replay
# (present.replay_style), the page and the bundle's figures name and colour them from this
RUN_TRACKS = {"recovery": ("with recovery", "method", 0), "no_recovery": ("without recovery", "baseline", 1)}
# label and colour per run, in the order drawn (the control first)
RUNS = {n: (label, hex_color(role, order)) for n, (label, role, order) in
        sorted(RUN_TRACKS.items(), key=lambda kv: -kv[1][2])}
CLIP = (-45.0, 90.0)  # once the robot has gone over, the margin is meaningless (-180 deg)
TILT_CLIP = 90.0  # body tilt beyond +-90 deg: the robot is on its side or back
TIME = "time (s)"
# the margin plot: its title, its three rows' axis titles (FASM, SSM / NESM, critical edge)
MARGIN_TITLE = "Stability margin against time"
MARGIN_AXES = ("FASM margin (°)", "SSM / NESM (m)", "critical edge")
EXTRA = (("ssm_m", "SSM", "dot"), ("nesm_m", "NESM", "dashdot"))  # trace key, name, dash (in the run's colour)
DETECTED = (ROLES["event"], "dash")  # the tipping judgment fired (colour, dash)
LANDED = (ROLES["reference"], "dot")  # the adjustment leg landed
TILT_TITLE, TILT_AXIS = "Platform and body tilt", "tilt (°)"
FORCES_TITLE = "Foot normal forces per leg"
# six legs, six hues far apart (the palette's two oranges and two greens read as one colour
# for legs 2/5 and 3/6); legs 4-6 dashed as well, for readers who do not tell hues apart;
# the QP's force for a foot dotted and thin in its leg's colour
LEG_COLORS = [kit.PALETTE[i] for i in (0, 1, 2, 3, 6, 7)]
QP_LINE = ("dot", 1.0)


def _run_order(traces: Mapping) -> list[str]:
    return [n for n in RUNS if n in traces] + [n for n in traces if n not in RUNS and "fasm_deg" in traces[n]]


def _style(name: str, i: int) -> tuple[str, str]:
    return RUNS.get(name, (name.replace("_", " "), kit.PALETTE[(i + 2) % len(kit.PALETTE)]))


def threshold_label(thr: float) -> str:
    return f"threshold {thr:g}°"


def margin_runs(summary: dict, traces: Mapping) -> list[dict]:
    """What the margin plot draws of each run: name, label and colour; its times from the
    end of the drop onto the feet (1 s) to where it tipped over (after the fall the margin
    means nothing); FASM clipped to CLIP; SSM and NESM {name: (values, dash)} where the trace
    has them; the critical edge's name (Table II) per time; when it tipped over (None: it
    did not)."""
    runs = summary.get("runs", {})
    out = []
    for i, name in enumerate(_run_order(traces)):
        tr, r = traces[name], runs.get(name, {})
        t = np.asarray(tr["time_s"], dtype=float)
        keep = t >= 1.0  # the first second is the drop onto the feet
        tipped = r["tipped_at_s"] if r.get("tipped") and r.get("tipped_at_s") is not None else None
        if tipped is not None:
            keep &= t <= tipped
        label, color = _style(name, i)
        extra = {nice: (np.asarray(tr[key], dtype=float)[keep], dash) for key, nice, dash in EXTRA if key in tr}
        edges = [edge_name(int(a), int(b)) for a, b in zip(np.asarray(tr["edge_leg_a"])[keep],
                                                            np.asarray(tr["edge_leg_b"])[keep])] if "edge_leg_a" in tr else []
        out.append({"name": name, "label": label, "color": color, "t": t[keep], "extra": extra, "edges": edges,
                    "fasm": np.clip(np.asarray(tr["fasm_deg"], dtype=float)[keep], *CLIP), "tipped_at_s": tipped})
    return out


def margin_events(summary: dict) -> list[tuple[float, str, str, str]]:
    """The vertical lines of the margin plot: (time, text, colour, dash) of the detection
    and of each adjustment leg's landing, in the run with recovery."""
    rec = summary.get("runs", {}).get("recovery", {})
    out = []
    if rec.get("detection_time_s") is not None:
        out.append((float(rec["detection_time_s"]), f"detected {rec['detection_time_s']:.2f} s", *DETECTED))
    for a in rec.get("adjustments", []) or []:
        if a.get("land_time_s") is not None:
            out.append((float(a["land_time_s"]), f"leg {a['leg']} lands", *LANDED))
    return out


def threshold_span(traces: Mapping) -> list[float]:
    """The threshold line's times: from 1 s to the end of the longest run."""
    return [1.0, max([float(np.asarray(traces[n]["time_s"])[-1]) for n in _run_order(traces)] or [1.0])]


def margin_caption(thr: float) -> str:
    return (f"Force-angle stability margin (Eq. 3-9) of the critical support edge; below the {thr:g}° threshold the "
            "robot is judged to be tipping. The dashed vertical line is the detection, dotted lines the adjustment "
            "leg landing; the cross marks where the robot tipped over (its lines end there). Margins are clipped to "
            f"[{CLIP[0]:g}°, {CLIP[1]:g}°]. Beneath: the edge the margin is measured about, named as in Table II "
            "(a35 is the edge between feet 3 and 5). SSM and NESM of the same polygon (right axis): click their legend "
            "entries (the bundle's figure draws them in a row of their own).")


def _margin_traces(runs: list[dict]) -> list[dict]:
    data = []
    for r in runs:
        step = kit.stride(len(r["t"]))
        label, color, name = r["label"], r["color"], r["name"]
        x = kit.series(r["t"], step, digits=3)
        data.append(kit.line(x, kit.series(r["fasm"], step, digits=3), f"FASM {label}", color, legendgroup=name,
                             hovertemplate="%{y:.1f}°<extra>FASM " + label + "</extra>"))
        for nice, (v, dash) in r["extra"].items():
            data.append(kit.line(x, kit.series(v, step, digits=4), f"{nice} {label} (m)", color, dash=dash, width=1.5,
                                 yaxis="y2", visible="legendonly", legendgroup=name))
        if r["edges"]:
            data.append({"type": "scatter", "mode": "markers", "x": x, "y": r["edges"][::step], "yaxis": "y3",
                         "name": f"critical edge {label}", "legendgroup": name, "showlegend": False,
                         "marker": {"color": color, "size": 3}, "hovertemplate": "%{y}<extra>" + label + "</extra>"})
        if r["tipped_at_s"] is not None:
            data.append({"type": "scatter", "mode": "markers", "x": [r["tipped_at_s"]], "y": [CLIP[0]],
                         "name": f"tipped over ({label})", "marker": {"symbol": "x", "size": 14, "color": color},
                         "hovertemplate": "tipped over at %{x:.2f} s<extra></extra>"})
    return data


def margin_view(summary: dict, traces: Mapping) -> dict:
    thr = float(summary.get("threshold_deg", 20.0))
    data = _margin_traces(margin_runs(summary, traces))
    # the threshold as a trace too, so it has a legend entry and hover text
    data.append(kit.line(threshold_span(traces), [thr, thr], threshold_label(thr), kit.TARGET, dash="dash",
                         hoverinfo="skip"))
    shapes = [{"type": "line", "xref": "paper", "x0": 0, "x1": 1, "y0": 0, "y1": 0, "yref": "y",
               "line": {"color": ROLES["zero"], "width": 1}}]
    notes = []
    for x, text, color, dash in margin_events(summary):
        s, n = kit.vline(x, text, color, dash=dash)
        if dash == LANDED[1]:
            n["yanchor"], n["y"] = "top", 0.97
        shapes.append(s)
        notes.append(n)
    fasm, extra, edge = MARGIN_AXES
    layout = {"xaxis": kit.axis(TIME, anchor="free", position=0.0),
              "yaxis": kit.axis(fasm, range=[CLIP[0] - 5, CLIP[1]], domain=[0.3, 1.0]),
              # no zero line of its own: it fell off the FASM zero, a stray line across the plot
              "yaxis2": kit.axis(extra, overlaying="y", side="right", showgrid=False, zeroline=False),
              "yaxis3": kit.axis(edge, domain=[0.0, 0.2], anchor="x", type="category"),
              "shapes": shapes, "annotations": notes, "hovermode": "x unified", "margin": {"l": 56, "r": 64, "t": 36, "b": 44},
              # the legend clears the detection's label above the plot (on a phone its last rows covered it)
              "legend": {"orientation": "h", "y": 1.08, "yanchor": "bottom", "x": 0}}
    return kit.panel("margin", MARGIN_TITLE, margin_caption(thr), kit.figure(data, layout), height=520)


def force_runs(traces: Mapping) -> list[dict]:
    """What the force plot draws of each run with foot forces: its title (the run's label,
    and what the dotted lines are when the QP ran), times, each leg's F_z in kN and, per
    leg the QP gave a force, that force in kN (NaN where the QP did not run)."""
    out = []
    for p, name in enumerate(n for n in _run_order(traces) if "foot_fz_n" in traces[n]):
        tr = traces[name]
        fz = np.asarray(tr["foot_fz_n"], dtype=float) / 1e3
        qp = {}
        if "qp_fz_n" in tr:
            q = np.asarray(tr["qp_fz_n"], dtype=float)
            qp = {leg: np.where(q[:, leg] != 0, q[:, leg] / 1e3, np.nan) for leg in range(q.shape[1]) if np.any(q[:, leg])}
        label = _style(name, p)[0]
        out.append({"name": name, "label": label, "title": label + ("; dotted: the QP's force" if qp else ""),
                    "t": np.asarray(tr["time_s"], dtype=float), "fz": fz, "qp": qp})
    return out


def leg_line(leg: int) -> tuple[str, str, float]:
    """(colour, dash, width) of a leg's measured force (legs from 0)."""
    return LEG_COLORS[leg % len(LEG_COLORS)], "solid" if leg < 3 else "dash", 1.5


def force_axis(label: str) -> str:
    return f"F_z {label} (kN)"


def forces_view(traces: Mapping) -> dict | None:
    runs = force_runs(traces)
    if not runs:
        return None
    doms = kit.stacked(len(runs), gap=0.12)
    data, layout, notes = [], {"hovermode": "x unified"}, []
    for p, r in enumerate(runs):
        step = kit.stride(len(r["t"]))
        ax = "" if p == 0 else str(p + 1)
        x = kit.series(r["t"], step, digits=3)
        for leg in range(r["fz"].shape[1]):
            color, dash, width = leg_line(leg)
            data.append(kit.line(x, kit.series(r["fz"][:, leg], step, digits=3), f"leg {leg + 1}", color, width=width,
                                 dash=dash, xaxis=f"x{ax}", yaxis=f"y{ax}", legendgroup=f"leg{leg + 1}", showlegend=p == 0))
            if leg in r["qp"]:
                data.append(kit.line(x, kit.series(r["qp"][leg], step, digits=3), f"leg {leg + 1}: QP", color,
                                     dash=QP_LINE[0], width=QP_LINE[1], xaxis=f"x{ax}", yaxis=f"y{ax}",
                                     legendgroup=f"leg{leg + 1}", showlegend=False))
        layout[f"yaxis{ax}"] = kit.axis(force_axis(r["label"]), domain=doms[p], anchor=f"x{ax}")
        layout[f"xaxis{ax}"] = kit.axis(TIME if p == len(runs) - 1 else "", anchor=f"y{ax}",
                                        matches="x" if p else None, showticklabels=p == len(runs) - 1)
        notes.append({"xref": "paper", "x": 0, "yref": "paper", "y": doms[p][1], "yanchor": "bottom", "xanchor": "left",
                      "text": f"<b>{r['title']}</b>", "showarrow": False})
    layout["annotations"] = notes
    cap = ("Normal force of each foot on the ground (legs numbered as in the paper, 1-6; legs 4-6 dashed); a foot in "
           "the air carries none. Dotted, in the leg's colour: the force the QP (Eq. 16-24) asks of that foot while it runs.")
    return kit.panel("forces", FORCES_TITLE, cap, kit.figure(data, layout), height=200 * len(runs) + 120)


def tilt_lines(traces: Mapping) -> list[dict]:
    """The tilt plot's lines: per run the body's tilt relative to the ground, clipped to
    +-TILT_CLIP, in the run's colour; then the platform's tilt from the run that lasted
    longest (a run that fell ends early), grey and dashed. Each {name, color, dash, t, y}."""
    names = _run_order(traces)
    out = []
    for i, name in enumerate(names):
        tr = traces[name]
        if "tilt_rel_deg" in tr:
            label, color = _style(name, i)
            out.append({"name": f"body vs ground, {label}", "color": color, "dash": "solid", "t": tr["time_s"],
                        "y": np.clip(np.asarray(tr["tilt_rel_deg"], dtype=float), -TILT_CLIP, TILT_CLIP)})
    tilted = [n for n in names if "platform_tilt_deg" in traces[n] and np.any(traces[n]["platform_tilt_deg"])]
    if tilted:
        tr = traces[max(tilted, key=lambda n: float(np.asarray(traces[n]["time_s"])[-1]))]
        out.append({"name": "platform tilt", "color": kit.NEUTRAL, "dash": "dash", "t": tr["time_s"],
                    "y": np.asarray(tr["platform_tilt_deg"], dtype=float)})
    return out


def tilt_view(traces: Mapping) -> dict | None:
    data = []
    for ln in tilt_lines(traces):
        step = kit.stride(len(ln["t"]))
        data.append(kit.line(kit.series(ln["t"], step, digits=3), kit.series(ln["y"], step, digits=3), ln["name"],
                             ln["color"], dash=ln["dash"]))
    if not data:
        return None
    layout = {"xaxis": kit.axis(TIME), "yaxis": kit.axis(TILT_AXIS), "hovermode": "x unified"}
    return kit.panel("tilt", TILT_TITLE, f"Body tilt relative to the ground it stands on, clipped to ±{TILT_CLIP:g}°; "
                     "the platform's tilt dashed.", kit.figure(data, layout), height=320)


def sweep_view(sweep: dict) -> dict:
    th = [float(d) for d in sweep["directions_deg"]]
    width = 360.0 / max(len(th), 1) * 0.8
    succ = [None if v is None else 100 * v for v in sweep["success_rate"]]
    tip = [None if v is None else 100 * v for v in sweep["tip_rate_without_recovery"]]
    data = [{"type": "barpolar", "r": succ, "theta": th, "width": [width] * len(th), "name": "upright with recovery (%)",
             "marker": {"color": kit.METHOD, "opacity": 0.65},
             "hovertemplate": "downhill %{theta:.0f}°: %{r:.0f} % upright<extra></extra>"},
            {"type": "scatterpolar", "mode": "lines+markers", "r": tip + tip[:1], "theta": th + th[:1],
             "name": "tips without recovery (%)", "line": {"color": kit.CONTROL, "width": 2},
             "hovertemplate": "downhill %{theta:.0f}°: %{r:.0f} % tip<extra></extra>"}]
    layout = {"polar": {"radialaxis": {"range": [0, 100], "ticksuffix": " %", "angle": 90},
                        "angularaxis": {"rotation": 90, "direction": "counterclockwise", "ticksuffix": "°"}},
              "hovermode": "closest"}
    overall = sweep.get("overall_success_rate")
    cap = ("Share of runs (over the swept tripods) that stay upright with recovery, and that tip without it, per "
           "downhill direction: 0° = the robot's front goes down, 90° = its left side."
           + (f" Overall {100 * overall:.0f} % upright with recovery." if overall is not None else ""))
    return kit.panel("sweep", "Recovery success per tilt direction", cap, kit.figure(data, layout), height=460)


def adjustments_table(summary: dict) -> dict | None:
    adj = (summary.get("runs", {}).get("recovery", {}) or {}).get("adjustments") or []
    if not adj:
        return None
    rows = []
    for a in adj:
        fh = a.get("foothold_body_m") or []
        rows.append([a.get("detect_time_s"), a.get("edge") or "–", a.get("margin_at_detection_deg"), a.get("time_to_tip_s"),
                     a.get("leg") if a.get("leg") is not None else "none (no reachable foothold)",
                     (a.get("foothold_label") or "") + (" (" + ", ".join(f"{v:.2f}" for v in fh) + ")" if fh else ""),
                     a.get("swing_s"),
                     None if a.get("leg") is None else kit.cell(a.get("lands_before_tip"), met=bool(a.get("lands_before_tip")),
                                                                text="yes" if a.get("lands_before_tip") else "no"),
                     a.get("margin_before_landing_deg"),
                     None if a.get("margin_after_landing_deg") is None else
                     kit.cell(a["margin_after_landing_deg"], "°", met=a["margin_after_landing_deg"] >= summary.get("threshold_deg", 20.0))])
    cols = ["detected (s)", "tipping edge", "margin at detection (°)", "time to tip (s)", "adjustment leg",
            "foothold (body frame, m)", "swing (s)", "lands before tip", "margin before landing (°)",
            "margin after landing (°)"]
    cap = ("Each time the margin fell below the threshold: the edge it tips about, the predicted time to tip (Eq. 15), "
           "the leg chosen from Table II and its foothold (Eq. 10-14). 'met': the margin after landing is back above the "
           "threshold.")
    return kit.panel("adjustments", "Adjustments", cap, table=kit.table(cols, rows))


def runs_table(summary: dict) -> dict:
    target = target_of(summary)
    rows = []
    for i, (name, r) in enumerate(summary.get("runs", {}).items()):
        label, _ = _style(name, i)
        met = target.met(r) if "tipped" in r else None
        rows.append([label, kit.cell(r.get("tipped"), met=met, text="tipped" if r.get("tipped") else "upright"),
                     r.get("tipped_at_s"), r.get("first_below_threshold_s"), r.get("min_margin_deg"),
                     r.get("final_margin_deg"), r.get("final_body_tilt_deg"), r.get("static_tip_deg"), r.get("max_tilt_deg")])
    cols = ["run", "outcome", "tipped at (s)", "first below threshold (s)", "min margin (°)", "final margin (°)",
            "final body tilt (°)", "static tip angle (°)", "max platform tilt (°)"]
    return kit.panel("runs", "Runs with and without recovery", f"'met': the run meets the target: {target.text}.",
                     table=kit.table(cols, rows))


def views(summary: dict, traces: Mapping) -> list[dict]:
    out = [margin_view(summary, traces)]
    out += [v for v in (adjustments_table(summary), runs_table(summary), forces_view(traces), tilt_view(traces)) if v]
    if summary.get("sweep"):
        out.append(sweep_view(summary["sweep"]))
    return out


def history_axis(spec: dict) -> dict | None:
    return None  # runs, not generations: the history is a table of runs


# form groups the dashboard opens first: what a user sets for a tipping run
FORM_OPEN = ["scenario", "recovery.enabled", "sweep"]


def study_views(study: dict, points: list[dict]) -> list[dict]:
    """A tilt-direction study (points over scenario.downhill_deg, tripods and recovery on /
    off) as the polar success rate: per direction, the share of recovery runs that stay
    upright, and of the runs without recovery that tip (every point also runs the robot
    without recovery as its own control)."""
    by_dir: dict[float, dict[str, list[bool]]] = {}
    for p in points:
        s, spec = p.get("summary"), p["spec"]
        if p["status"] != "succeeded" or not s or spec.get("scenario", {}).get("type") != "tilt":
            continue
        d = by_dir.setdefault(float(s["scenario"]["downhill_deg"]) % 360.0, {"upright": [], "tipped": []})
        runs = s["runs"]
        if "recovery" in runs:
            d["upright"].append(not runs["recovery"]["tipped"])
        d["tipped"].append(bool(runs["no_recovery"]["tipped"]))
    if not by_dir:
        return []
    dirs = sorted(by_dir)
    mean = lambda xs: float(np.mean(xs)) if xs else None  # noqa: E731
    success = [mean(by_dir[d]["upright"]) for d in dirs]
    done = [x for x in success if x is not None]
    sweep = {"directions_deg": dirs, "success_rate": success,
             "tip_rate_without_recovery": [mean(by_dir[d]["tipped"]) for d in dirs],
             "overall_success_rate": float(np.mean(done)) if done else None}
    panel = sweep_view(sweep)
    panel["id"] = "study-sweep"
    return [panel]

"""Dashboard views of the tipping kind (paper 002): the FASM margin against time with the
threshold, detection and landing marked, with and without recovery (SSM and NESM one click
away in the legend); foot normal forces per leg; body and platform tilt; the direction
sweep as a polar success rate; the adjustments and runs as tables. Legs are numbered as in
the paper, from 1."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.jobs import viewkit as kit
from app.jobs.tipping.evidence import target_of
from app.jobs.tipping.present import replay_style

# labels and colours as the replay shows them (present.replay_style, app/core/colors.py roles)
RUNS = {t.name: (t.label, t.color) for t in sorted(replay_style(["no_recovery", "recovery"]), key=lambda t: -t.order)}
CLIP = (-45.0, 90.0)  # once the robot has gone over, the margin is meaningless (-180 deg)


def _run_order(traces: Mapping) -> list[str]:
    return [n for n in RUNS if n in traces] + [n for n in traces if n not in RUNS and "fasm_deg" in traces[n]]


def _style(name: str, i: int) -> tuple[str, str]:
    return RUNS.get(name, (name.replace("_", " "), kit.PALETTE[(i + 2) % len(kit.PALETTE)]))


def margin_view(summary: dict, traces: Mapping) -> dict:
    thr = float(summary.get("threshold_deg", 20.0))
    runs = summary.get("runs", {})
    data, shapes, notes = [], [], []
    for i, name in enumerate(_run_order(traces)):
        tr = traces[name]
        t = np.asarray(tr["time_s"], dtype=float)
        keep = t >= 1.0  # the first second is the drop onto the feet
        r = runs.get(name, {})
        if r.get("tipped") and r.get("tipped_at_s") is not None:
            keep &= t <= r["tipped_at_s"]  # after the fall the margin means nothing
        t = t[keep]
        step = kit.stride(len(t))
        label, color = _style(name, i)
        m = np.clip(np.asarray(tr["fasm_deg"], dtype=float)[keep], *CLIP)
        x = kit.series(t, step, digits=3)
        data.append(kit.line(x, kit.series(m, step, digits=3), f"FASM {label}", color, legendgroup=name,
                             hovertemplate="%{y:.1f}°<extra>FASM " + label + "</extra>"))
        for key, nice, dash in (("ssm_m", "SSM", "dot"), ("nesm_m", "NESM", "dashdot")):
            if key in tr:
                data.append(kit.line(x, kit.series(np.asarray(tr[key])[keep], step, digits=4), f"{nice} {label} (m)", color,
                                     dash=dash, width=1.5, yaxis="y2", visible="legendonly", legendgroup=name))
        if r.get("tipped") and r.get("tipped_at_s") is not None:
            data.append({"type": "scatter", "mode": "markers", "x": [r["tipped_at_s"]], "y": [CLIP[0]],
                         "name": f"tipped over ({label})", "marker": {"symbol": "x", "size": 14, "color": color},
                         "hovertemplate": "tipped over at %{x:.2f} s<extra></extra>"})
    # the threshold as a trace too, so it has a legend entry and hover text
    t_all = [float(np.asarray(traces[n]["time_s"])[-1]) for n in _run_order(traces)] or [1.0]
    data.append(kit.line([1.0, max(t_all)], [thr, thr], f"threshold {thr:g}°", kit.TARGET, dash="dash",
                         hoverinfo="skip"))
    shapes.append({"type": "line", "xref": "paper", "x0": 0, "x1": 1, "y0": 0, "y1": 0, "yref": "y",
                   "line": {"color": "#18202b", "width": 1}})
    rec = runs.get("recovery", {})
    if rec.get("detection_time_s") is not None:
        s, n = kit.vline(rec["detection_time_s"], f"detected {rec['detection_time_s']:.2f} s", "#b45309", dash="dash")
        shapes.append(s)
        notes.append(n)
    for a in rec.get("adjustments", []) or []:
        if a.get("land_time_s") is not None:
            s, n = kit.vline(a["land_time_s"], f"leg {a['leg']} lands", "#15803d")
            n["yanchor"], n["y"] = "top", 0.97
            shapes.append(s)
            notes.append(n)
    layout = {"xaxis": kit.axis("time (s)"), "yaxis": kit.axis("FASM margin (°)", range=[CLIP[0] - 5, CLIP[1]]),
              "yaxis2": kit.axis("SSM / NESM (m)", overlaying="y", side="right", showgrid=False),
              "shapes": shapes, "annotations": notes, "hovermode": "x unified", "margin": {"l": 56, "r": 64, "t": 36, "b": 44}}
    cap = (f"Force-angle stability margin (Eq. 3-9) of the critical support edge; below the {thr:g}° threshold the "
           "robot is judged to be tipping. The dashed vertical line is the detection, dotted lines the adjustment "
           "leg landing; the cross marks where the robot tipped over (its line ends there). Margins are clipped to "
           f"[{CLIP[0]:g}°, {CLIP[1]:g}°]. SSM and NESM: click their legend entries.")
    return kit.panel("margin", "Stability margin against time", cap, kit.figure(data, layout), height=430)


# six legs, six hues far apart (the palette's two oranges and two greens read as one colour
# for legs 2/5 and 3/6); legs 4-6 dashed as well, for readers who do not tell hues apart
LEG_COLORS = [kit.PALETTE[i] for i in (0, 1, 2, 3, 6, 7)]


def forces_view(traces: Mapping) -> dict | None:
    names = [n for n in _run_order(traces) if "foot_fz_n" in traces[n]]
    if not names:
        return None
    doms = kit.stacked(len(names), gap=0.12)
    data, layout, notes = [], {"hovermode": "x unified", "annotations": []}, []
    for p, name in enumerate(names):
        tr = traces[name]
        t = np.asarray(tr["time_s"], dtype=float)
        fz = np.asarray(tr["foot_fz_n"], dtype=float)
        step = kit.stride(len(t))
        ax = "" if p == 0 else str(p + 1)
        label, _ = _style(name, p)
        for leg in range(fz.shape[1]):
            data.append(kit.line(kit.series(t, step, digits=3), kit.series(fz[:, leg], step, scale=1e-3, digits=3),
                                 f"leg {leg + 1}", LEG_COLORS[leg % len(LEG_COLORS)], width=1.5,
                                 dash="solid" if leg < 3 else "dash", xaxis=f"x{ax}", yaxis=f"y{ax}",
                                 legendgroup=f"leg{leg + 1}", showlegend=p == 0))
        layout[f"yaxis{ax}"] = kit.axis(f"F_z {label} (kN)", domain=doms[p], anchor=f"x{ax}")
        layout[f"xaxis{ax}"] = kit.axis("time (s)" if p == len(names) - 1 else "", anchor=f"y{ax}",
                                        matches="x" if p else None, showticklabels=p == len(names) - 1)
        notes.append({"xref": "paper", "x": 0, "yref": "paper", "y": doms[p][1], "yanchor": "bottom", "xanchor": "left",
                      "text": f"<b>{label}</b>", "showarrow": False})
    layout["annotations"] = notes
    cap = "Normal force of each foot on the ground (legs numbered as in the paper, 1-6); a foot in the air carries none."
    return kit.panel("forces", "Foot normal forces per leg", cap, kit.figure(data, layout), height=200 * len(names) + 120)


def tilt_view(traces: Mapping) -> dict | None:
    names = _run_order(traces)
    data = []
    for i, name in enumerate(names):
        tr = traces[name]
        if "tilt_rel_deg" not in tr:
            continue
        t = np.asarray(tr["time_s"], dtype=float)
        step = kit.stride(len(t))
        label, color = _style(name, i)
        data.append(kit.line(kit.series(t, step, digits=3), kit.series(np.clip(tr["tilt_rel_deg"], -90, 90), step, digits=3),
                             f"body vs ground, {label}", color))
    # the platform's tilt from the run that lasted longest (a run that fell ends early)
    tilted = [n for n in names if "platform_tilt_deg" in traces[n] and np.any(traces[n]["platform_tilt_deg"])]
    if tilted:
        tr = traces[max(tilted, key=lambda n: float(np.asarray(traces[n]["time_s"])[-1]))]
        t = np.asarray(tr["time_s"], dtype=float)
        step = kit.stride(len(t))
        data.append(kit.line(kit.series(t, step, digits=3), kit.series(tr["platform_tilt_deg"], step, digits=3),
                             "platform tilt", kit.NEUTRAL, dash="dash"))
    if not data:
        return None
    layout = {"xaxis": kit.axis("time (s)"), "yaxis": kit.axis("tilt (°)"), "hovermode": "x unified"}
    return kit.panel("tilt", "Platform and body tilt", "Body tilt relative to the ground it stands on, clipped to ±90°.",
                     kit.figure(data, layout), height=320)


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

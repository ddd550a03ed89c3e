"""Dashboard views of a ``freegait`` job: plotly figure dicts built here, in the panel
shape the dashboard draws ({"id", "title", "caption", "figure": {"data", "layout"}}).

The first panel is the headline: the minefield seen from above (Fig. 9) with the walk's
footholds, the control's footholds (zones ignored) one click away, zones and safe areas
drawn as circles. Then SM and K_R against time (Fig. 8b-c) and the support/transfer
diagram (Fig. 8a).

What the minefield and margin plots draw is described once here (``minefield_runs``,
``margin_lines``, ``stop_spans`` and the names, titles and colours beside them): the page's
panels and the bundle's figures (app/jobs/freegait/plots.py) both draw from it (issue 25)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.core.colors import ROLES
from app.jobs.freegait.spec import TARGET

METHOD, CONTROL, ZONE, SAFE = ROLES["method"], ROLES["baseline"], ROLES["forbidden"], ROLES["safe_area"]
FAILURE = ROLES["failure"]  # a foothold in a forbidden zone; the body stopped
MAX_POINTS = 1500
MINEFIELD_TITLE = "Footholds over the minefield (Fig. 9)"
MARGINS_TITLE = "Stability and kinematic margins (Fig. 8b-c)"
GAIT_TITLE = "Support and transfer per leg (Fig. 8a)"
# the margins plot: (name, y axis title, colour, width in px) of its two rows' lines, the
# SM_min line (colour, dash, width), the body stops' shading (name, colour, opacity)
MARGIN_LINES = (("SM", "SM (m)", METHOD, 1.5), ("K_R", "K_R (m)", ROLES["reference"], 1.5))
SM_MIN = ("SM_min", ROLES["threshold"], "dash", 2.0)
STOPPED = ("body stopped", FAILURE, 0.12)
TRIPOD_1 = (0, 3, 4)  # legs 1, 4, 5 (from 0); tripod 2: legs 2, 3, 6


def _axis(title: str, **kw) -> dict:
    return {"title": {"text": title}, "gridcolor": "#e3e8ee", "zerolinecolor": "#b9c2cf", **kw}


def _panel(pid: str, title: str, caption: str, data: list[dict], layout: dict, height: int) -> dict:
    layout = {"height": height, "margin": {"l": 56, "r": 24, "t": 36, "b": 44}, **layout}
    return {"id": pid, "title": title, "caption": caption, "figure": {"data": data, "layout": layout}}


def _r(a, digits: int = 4) -> list:
    a = np.asarray(a, dtype=float)
    return [None if not np.isfinite(v) else round(float(v), digits) for v in a.reshape(-1)]


def _stride(n: int) -> int:
    return max(1, int(np.ceil(n / MAX_POINTS)))


def tripod_color(leg: int) -> str:
    """A leg's bar in the support/transfer diagram (legs from 0): tripod 1 blue, tripod 2 orange."""
    return METHOD if leg in TRIPOD_1 else CONTROL


def minefield_runs(s: dict, traces: Mapping) -> list[dict]:
    """The runs the minefield plot draws: the walk, then the control whose footholds the
    summary keeps (zones ignored). Each: its name in the legend ("walk", "control (unaware)"),
    colour, the body centre's path (None without a trace), the footholds outside and inside
    forbidden zones (the summary's rows), and whether the page shows it before a click."""
    ctl = s.get("control_footholds") or {}
    runs = [("walk", "walk", s.get("footholds_list") or [], METHOD, True)]
    if ctl.get("footholds"):
        runs.append((ctl["name"], f"control ({ctl['name']})", ctl["footholds"], CONTROL, False))
    return [{"name": name, "color": color, "shown": shown,
             "path": np.asarray(traces[key]["pos"], dtype=float)[:, :2] if key in traces else None,
             "ok": [r for r in feet if not r["in_zone"]], "bad": [r for r in feet if r["in_zone"]]}
            for key, name, feet, color, shown in runs]


def foothold_names(name: str) -> tuple[str, str, str]:
    """Legend names of a minefield run's body centre, footholds and footholds in zones."""
    return f"{name}: body centre", f"{name}: footholds", f"{name}: in a forbidden zone"


def margin_lines(s: dict, traces: Mapping) -> dict:
    """The margins plot of the walk: times, SM and K_R (each with its row's name, axis
    title, colour, width), SM_min, and the periods the body stood still."""
    tr = traces["walk"]
    t = np.asarray(tr["time_s"], dtype=float)
    return {"t": t, "lines": [(name, axis, color, width, np.asarray(tr[key], dtype=float)) for key, (name, axis, color, width)
                              in zip(("sm_m", "k_r_m"), MARGIN_LINES)],
            "sm_min": float(s.get("sm_min_m", 0.05)), "stops": stop_spans(t, np.asarray(tr["stop"]) > 0)}


def stop_spans(t: np.ndarray, stop: np.ndarray) -> list[tuple[float, float]]:
    """The periods with the body stopped, (start, end) s: from a stopped control period's
    start to the end of the last one (one control period after its start)."""
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.1
    edges = np.flatnonzero(np.diff(np.r_[0, stop.astype(int), 0]))
    return [(round(float(t[a]), 3), round(float(t[b - 1] + dt), 3)) for a, b in zip(edges[::2], edges[1::2])]


def _foot_traces(run: dict) -> list[dict]:
    body, feet, bad = foothold_names(run["name"])
    common = {"legendgroup": run["name"], "visible": True if run["shown"] else "legendonly"}
    out = []
    if run["path"] is not None:
        p = run["path"]
        st = _stride(len(p))
        out.append({"type": "scatter", "mode": "lines", "x": _r(p[::st, 0]), "y": _r(p[::st, 1]), "name": body,
                    "line": {"color": run["color"], "width": 1}, "hoverinfo": "skip", **common})
    for rows, name, marker, tag in ((run["ok"], feet, {"symbol": "circle-open", "size": 8, "color": run["color"]}, ""),
                                    (run["bad"], bad, {"symbol": "x", "size": 11, "color": FAILURE}, "IN ZONE: ")):
        if rows or not tag:
            out.append({"type": "scatter", "mode": "markers", "x": [r["x"] for r in rows], "y": [r["y"] for r in rows],
                        "name": name, "marker": marker, "customdata": [[r["leg"], r["t"]] for r in rows],
                        "hovertemplate": tag + "leg %{customdata[0]} at %{customdata[1]:.1f} s<br>(%{x:.3f}, %{y:.3f}) m"
                                         "<extra></extra>", **common})
    return out


def zone_discs(s: dict, lo, hi) -> list[dict]:
    """The zones near the footholds (within 0.2 m of [lo, hi]) as plotly circles: each its safe
    area (grey) and its forbidden disc (black)."""
    f = s.get("field", {})
    shapes = []
    for x, y in s.get("zones", []):
        if lo[0] - 0.2 <= x <= hi[0] + 0.2 and lo[1] - 0.2 <= y <= hi[1] + 0.2:
            for rad, col in ((f.get("safe_radius_m", 0.075), SAFE), (f.get("zone_radius_m", 0.025), ZONE)):
                shapes.append({"type": "circle", "xref": "x", "yref": "y", "x0": x - rad, "x1": x + rad, "y0": y - rad,
                               "y1": y + rad, "fillcolor": col, "line": {"width": 0}, "layer": "below"})
    return shapes


def minefield_view(s: dict, traces: Mapping) -> dict:
    f = s.get("field", {})
    runs = minefield_runs(s, traces)
    pts = [[p["x"], p["y"]] for r in runs for p in r["ok"] + r["bad"]]
    lo = np.min(pts, axis=0) - 0.3 if pts else np.array([-1.0, -1.0])
    hi = np.max(pts, axis=0) + 0.3 if pts else np.array([1.0, 1.0])
    shapes = zone_discs(s, lo, hi)
    # the ranges hold every disc drawn, safe area included (they were cut at the top and bottom)
    for d in shapes:
        lo, hi = np.minimum(lo, [d["x0"], d["y0"]]), np.maximum(hi, [d["x1"], d["y1"]])
    lo, hi = lo - 0.02, hi + 0.02
    data = [t for r in runs for t in _foot_traces(r)]
    walk = runs[0]
    cap = (f"Forbidden zones (black, {2 * f.get('zone_radius_m', 0.025):g} m) with their safe areas (grey, "
           f"{2 * f.get('safe_radius_m', 0.075):g} m) seen from above; circles are the footholds where the feet "
           f"touched down in MuJoCo, crosses those in a zone. Walk: {len(walk['bad'])} of "
           f"{len(walk['ok']) + len(walk['bad'])} footholds in zones.")
    if s.get("target_met") is not None:
        cap += f" Target ({TARGET.text}): {'met' if s['target_met'] else 'not met'}."
    for r in runs[1:]:
        cap += (f" {r['name'][0].upper() + r['name'][1:]} (click its legend entries): {len(r['bad'])} of "
                f"{len(r['ok']) + len(r['bad'])} in zones.")
    # constrain="domain": the equal scale narrows the plot instead of widening the x range (at 1280 px a
    # 0.3 m walk was a few pixels on -3..3 m); the legend above the plot, as elsewhere (below it, it sat on
    # the x axis title on a phone)
    layout = {"xaxis": _axis("x (m)", range=[round(float(lo[0]), 3), round(float(hi[0]), 3)], constrain="domain",
                             automargin=True),
              "yaxis": _axis("y (m)", range=[round(float(lo[1]), 3), round(float(hi[1]), 3)], scaleanchor="x",
                             scaleratio=1, constrain="domain", automargin=True),
              "shapes": shapes, "legend": {"orientation": "h", "x": 0, "y": 1.02, "yanchor": "bottom"}}
    return _panel("minefield", MINEFIELD_TITLE, cap, data, layout, 460)


def margins_view(s: dict, traces: Mapping) -> dict | None:
    if "walk" not in traces:
        return None
    m = margin_lines(s, traces)
    t = m["t"]
    st = _stride(len(t))
    data = [{"type": "scatter", "mode": "lines", "x": _r(t[::st], 2), "y": _r(y[::st]), "name": name,
             "line": {"color": color, "width": width}, **({"xaxis": "x2", "yaxis": "y2"} if i else {})}
            for i, (name, _, color, width, y) in enumerate(m["lines"])]
    name, color, dash, width = SM_MIN
    data.append({"type": "scatter", "mode": "lines", "x": [float(t[0]), float(t[-1])], "y": [m["sm_min"]] * 2,
                 "name": name, "line": {"color": color, "dash": dash, "width": width}})
    stopped, fill, opacity = STOPPED
    shapes = [{"type": "rect", "xref": "x", "yref": "paper", "x0": a, "x1": b, "y0": 0, "y1": 1, "fillcolor": fill,
               "opacity": opacity, "line": {"width": 0}, "layer": "below", "name": stopped, "legendgroup": "stopped",
               "showlegend": i == 0} for i, (a, b) in enumerate(m["stops"])]
    shapes.append({"type": "line", "xref": "paper", "x0": 0, "x1": 1, "yref": "y2", "y0": 0, "y1": 0,
                   "line": {"color": ROLES["zero"], "width": 1}})  # K_R <= 0: a leg at its workspace's edge
    # two panels, each with its own x axis (one x axis sat at the upper panel's foot, its
    # title over the lower panel, which had no tick labels): time labelled once, at the bottom
    (_, sm_axis, *_), (_, kr_axis, *_) = m["lines"]
    layout = {"xaxis": _axis("", anchor="y", matches="x2", showticklabels=False),
              "xaxis2": _axis("time (s)", anchor="y2"),
              "yaxis": _axis(sm_axis, domain=[0.56, 1.0], anchor="x"),
              "yaxis2": _axis(kr_axis, domain=[0.0, 0.44], anchor="x2"), "shapes": shapes, "hovermode": "x unified"}
    cap = ("Absolute stability margin of the feet in support (Def. 1) and the robot's reduced kinematic margin "
           "(Eq. 15) every 0.1 s control period; shaded red: periods with the body stopped.")
    return _panel("margins", MARGINS_TITLE, cap, data, layout, 420)


def gait_view(traces: Mapping) -> dict | None:
    if "walk" not in traces:
        return None
    tr = traces["walk"]
    t = np.asarray(tr["time_s"], dtype=float)
    ph = np.asarray(tr["phase"])
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.1
    data = []
    for leg in range(6):
        sup = ph[:, leg] == 0
        edges = np.flatnonzero(np.diff(np.r_[0, sup.astype(int), 0]))
        xs, ys = [], []
        for a, b in zip(edges[::2], edges[1::2]):
            xs += [round(float(t[a]), 2), round(float(t[b - 1] + dt), 2), None]
            ys += [leg + 1, leg + 1, None]
        data.append({"type": "scatter", "mode": "lines", "x": xs, "y": ys, "name": f"leg {leg + 1}",
                     "line": {"color": tripod_color(leg), "width": 9}, "showlegend": False,
                     "hovertemplate": f"leg {leg + 1} in support<extra></extra>"})
    layout = {"xaxis": _axis("time (s)"), "yaxis": _axis("leg", autorange="reversed", dtick=1)}
    cap = "Support phases as bars, transfers as gaps; tripod 1 (legs 1, 4, 5) blue, tripod 2 (legs 2, 3, 6) orange."
    return _panel("gait", GAIT_TITLE, cap, data, layout, 300)


def views(summary: dict, traces: Mapping) -> list[dict]:
    out = [minefield_view(summary, traces)]
    out += [v for v in (margins_view(summary, traces), gait_view(traces)) if v]
    return out

"""Dashboard views of a ``freegait`` job: plotly figure dicts built here, in the panel
shape the dashboard draws ({"id", "title", "caption", "figure": {"data", "layout"}}).

The first panel is the headline: the minefield seen from above (Fig. 9) with the walk's
footholds, the control's footholds (zones ignored) one click away, zones and safe areas
drawn as circles. Then SM and K_R against time (Fig. 8b-c) and the support/transfer
diagram (Fig. 8a)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.jobs.freegait.spec import TARGET

METHOD, CONTROL, ZONE, SAFE = "#0b5cad", "#c2410c", "#111111", "#b8bec7"
MAX_POINTS = 1500


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


def minefield_view(s: dict, traces: Mapping) -> dict:
    f = s.get("field", {})
    feet = s.get("footholds_list") or []
    ctl = s.get("control_footholds") or {}
    pts = [[p["x"], p["y"]] for p in feet] + [[p["x"], p["y"]] for p in (ctl.get("footholds") or [])]
    lo = np.min(pts, axis=0) - 0.3 if pts else np.array([-1.0, -1.0])
    hi = np.max(pts, axis=0) + 0.3 if pts else np.array([1.0, 1.0])
    shapes = []
    for x, y in s.get("zones", []):
        if lo[0] - 0.2 <= x <= hi[0] + 0.2 and lo[1] - 0.2 <= y <= hi[1] + 0.2:
            for rad, col in ((f.get("safe_radius_m", 0.075), SAFE), (f.get("zone_radius_m", 0.025), ZONE)):
                shapes.append({"type": "circle", "xref": "x", "yref": "y", "x0": x - rad, "x1": x + rad, "y0": y - rad,
                               "y1": y + rad, "fillcolor": col, "line": {"width": 0}, "layer": "below"})
    data = []
    if "walk" in traces:
        p = np.asarray(traces["walk"]["pos"])
        st = _stride(len(p))
        data.append({"type": "scatter", "mode": "lines", "x": _r(p[::st, 0]), "y": _r(p[::st, 1]), "name": "body centre",
                     "line": {"color": METHOD, "width": 1}, "hoverinfo": "skip"})

    def foot_trace(rows, name, color, visible=True):
        ok = [r for r in rows if not r["in_zone"]]
        bad = [r for r in rows if r["in_zone"]]
        out = [{"type": "scatter", "mode": "markers", "x": [r["x"] for r in ok], "y": [r["y"] for r in ok],
                "name": f"{name}: footholds", "legendgroup": name, "visible": visible,
                "marker": {"symbol": "circle-open", "size": 8, "color": color},
                "customdata": [[r["leg"], r["t"]] for r in ok],
                "hovertemplate": "leg %{customdata[0]} at %{customdata[1]:.1f} s<br>(%{x:.3f}, %{y:.3f}) m<extra></extra>"}]
        if bad:
            out.append({"type": "scatter", "mode": "markers", "x": [r["x"] for r in bad], "y": [r["y"] for r in bad],
                        "name": f"{name}: in a forbidden zone", "legendgroup": name, "visible": visible,
                        "marker": {"symbol": "x", "size": 11, "color": "#dc2626"},
                        "customdata": [[r["leg"], r["t"]] for r in bad],
                        "hovertemplate": "IN ZONE: leg %{customdata[0]} at %{customdata[1]:.1f} s<extra></extra>"})
        return out

    data += foot_trace(feet, "walk", METHOD)
    if ctl.get("footholds"):
        data += foot_trace(ctl["footholds"], f"control ({ctl['name']})", CONTROL, "legendonly")
    n_bad = sum(r["in_zone"] for r in feet)
    n_ctl = sum(r["in_zone"] for r in ctl.get("footholds") or [])
    cap = (f"Forbidden zones (black, {2 * f.get('zone_radius_m', 0.025):g} m) with their safe areas (grey, "
           f"{2 * f.get('safe_radius_m', 0.075):g} m) seen from above; circles are the footholds where the feet "
           f"touched down in MuJoCo. Walk: {n_bad} of {len(feet)} footholds in zones.")
    if s.get("target_met") is not None:
        cap += f" Target ({TARGET.text}): {'met' if s['target_met'] else 'not met'}."
    if ctl.get("footholds"):
        cap += (f" Control ({ctl['name']}, click its legend entry): {n_ctl} of {len(ctl['footholds'])} in zones.")
    layout = {"xaxis": _axis("x (m)", range=[float(lo[0]), float(hi[0])]),
              "yaxis": _axis("y (m)", range=[float(lo[1]), float(hi[1])], scaleanchor="x", scaleratio=1),
              "shapes": shapes, "legend": {"orientation": "h", "y": -0.18}}
    return _panel("minefield", "Footholds over the minefield (Fig. 9)", cap, data, layout, 460)


def margins_view(s: dict, traces: Mapping) -> dict | None:
    if "walk" not in traces:
        return None
    tr = traces["walk"]
    t = np.asarray(tr["time_s"], dtype=float)
    st = _stride(len(t))
    stop = np.asarray(tr["stop"])[::st] > 0
    data = [{"type": "scatter", "mode": "lines", "x": _r(t[::st], 2), "y": _r(np.asarray(tr["sm_m"])[::st]),
             "name": "SM", "line": {"color": METHOD, "width": 1.5}},
            {"type": "scatter", "mode": "lines", "x": _r(t[::st], 2), "y": _r(np.asarray(tr["k_r_m"])[::st]),
             "name": "K_R", "line": {"color": "#15803d", "width": 1.5}, "xaxis": "x2", "yaxis": "y2"},
            {"type": "scatter", "mode": "lines", "x": [float(t[0]), float(t[-1])],
             "y": [s.get("sm_min_m", 0.05)] * 2, "name": "SM_min", "line": {"color": "#6b7280", "dash": "dash"}}]
    if stop.any():
        data.append({"type": "scatter", "mode": "markers", "x": _r(t[::st][stop], 2), "y": [0.0] * int(stop.sum()),
                     "name": "body stopped", "marker": {"color": "#dc2626", "size": 4, "symbol": "square"}})
    # two panels, each with its own x axis (one x axis sat at the upper panel's foot, its
    # title over the lower panel, which had no tick labels): time labelled once, at the bottom
    layout = {"xaxis": _axis("", anchor="y", matches="x2", showticklabels=False),
              "xaxis2": _axis("time (s)", anchor="y2"),
              "yaxis": _axis("SM (m)", domain=[0.56, 1.0], anchor="x"),
              "yaxis2": _axis("K_R (m)", domain=[0.0, 0.44], anchor="x2"), "hovermode": "x unified"}
    cap = ("Absolute stability margin of the feet in support (Def. 1) and the robot's reduced kinematic margin "
           "(Eq. 15) every 0.1 s control period; red squares mark periods with the body stopped.")
    return _panel("margins", "Stability and kinematic margins (Fig. 8b-c)", cap, data, layout, 420)


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
                     "line": {"color": METHOD if leg in (0, 3, 4) else CONTROL, "width": 9}, "showlegend": False,
                     "hovertemplate": f"leg {leg + 1} in support<extra></extra>"})
    layout = {"xaxis": _axis("time (s)"), "yaxis": _axis("leg", autorange="reversed", dtick=1)}
    cap = "Support phases as bars, transfers as gaps; tripod 1 (legs 1, 4, 5) blue, tripod 2 (legs 2, 3, 6) orange."
    return _panel("gait", "Support and transfer per leg (Fig. 8a)", cap, data, layout, 300)


def views(summary: dict, traces: Mapping) -> list[dict]:
    out = [minefield_view(summary, traces)]
    out += [v for v in (margins_view(summary, traces), gait_view(traces)) if v]
    return out

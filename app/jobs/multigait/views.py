"""Dashboard views of the multigait kind (paper 001): the map with its obstacles, start and
goal, the RRT-MP tree coloured by gait and the final plan; the pivot traces of the evolved
gaits; the per-gait trials; the reuse experiment (Tables III-IV); the composed-vs-simulated
check against node depth (never against time)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.jobs import viewkit as kit


def gait_color(j: int) -> str:
    return kit.PALETTE[j % len(kit.PALETTE)]


def _tree(summary: dict, traces: Mapping) -> dict:
    t = summary.get("tree") or {}
    out = {"pos": np.asarray(t.get("pos_mu", []), dtype=float).reshape(-1, 3),
           "parent": np.asarray(t.get("parent", []), dtype=int), "gait": np.asarray(t.get("gait", []), dtype=int),
           "plan_node": t.get("plan_node"), "paths": None}
    tr = traces.get("tree") if hasattr(traces, "get") else None
    if tr is not None and "paths_mu" in tr:
        p = np.asarray(tr["paths_mu"], dtype=float)
        if len(p) == len(out["pos"]):
            out["paths"] = p
    return out


def plan_nodes(tree: dict) -> list[int]:
    node = tree["plan_node"]
    if node is None or not len(tree["pos"]):
        return []
    path = [int(node)]
    while path[-1] > 0 and tree["parent"][path[-1]] >= 0 and len(path) <= len(tree["pos"]):
        path.append(int(tree["parent"][path[-1]]))
    return path[::-1]


def _xy_of_edge(tree: dict, i: int) -> tuple[list, list]:
    if tree["paths"] is not None:
        p = tree["paths"][i]
        return kit.series(p[:, 0], digits=3), kit.series(p[:, 1], digits=3)
    a = int(tree["parent"][i])
    return [float(tree["pos"][a, 0]), float(tree["pos"][i, 0])], [float(tree["pos"][a, 1]), float(tree["pos"][i, 1])]


def plan_label(gaits: list[int], most: int = 8) -> str:
    """The plan's legend entry: its gaits in order, at most `most` of them a line and the lines
    about even (on one line a 17-gait plan ran past a phone's right edge)."""
    per_line = -(-len(gaits) // -(-len(gaits) // most)) if gaits else most
    lines = [" → ".join(str(g) for g in gaits[i:i + per_line]) for i in range(0, len(gaits), per_line)]
    return f"plan ({len(gaits)} gaits:{'<br>' if len(lines) > 1 else ' '}" + " →<br>".join(lines) + ")"


def map_view(summary: dict, traces: Mapping) -> dict:
    pm = summary["map"]
    tree = _tree(summary, traces)
    W, H = float(pm["width_mu"]), float(pm["height_mu"])
    shapes = [{"type": "rect", "x0": 0, "y0": 0, "x1": W, "y1": H, "line": {"color": "#18202b", "width": 2},
               "layer": "below"}]
    for (cx, cy, cz), (hx, hy, hz) in pm.get("terrain_boxes", []):
        g = int(max(120, 235 - 40 * (cz + hz)))
        shapes.append({"type": "rect", "x0": cx - hx, "y0": cy - hy, "x1": cx + hx, "y1": cy + hy, "layer": "below",
                       "fillcolor": f"rgb({g},{g},{g})", "line": {"width": 0}})
    for x0, y0, x1, y1 in pm.get("obstacles", []):
        shapes.append({"type": "rect", "x0": x0, "y0": y0, "x1": x1, "y1": y1, "fillcolor": "#374151",
                       "line": {"color": "#111827", "width": 1}})
    data: list[dict] = []
    pos = tree["pos"]
    cell = float(pm.get("cell_mu", 1.0))
    if len(pos):
        cells = np.unique(np.floor(pos[:, :2] / cell).astype(int), axis=0)
        nx, ny = int(np.ceil(W / cell)), int(np.ceil(H / cell))
        z = np.full((ny, nx), None, dtype=object)
        for cx, cy in cells:
            if 0 <= cx < nx and 0 <= cy < ny:
                z[cy, cx] = 1
        data.append({"type": "heatmap", "x": [(i + 0.5) * cell for i in range(nx)], "y": [(j + 0.5) * cell for j in range(ny)],
                     "z": z.tolist(), "colorscale": [[0, "#bbf7d0"], [1, "#bbf7d0"]], "showscale": False,
                     "name": f"covered cells ({len(cells)})", "hovertemplate": "covered cell<extra></extra>",
                     "showlegend": True, "opacity": 0.7})
        for j in sorted(set(tree["gait"][1:].tolist())):
            xs, ys = [], []
            for i in range(1, len(pos)):
                if tree["gait"][i] != j:
                    continue
                x, y = _xy_of_edge(tree, i)
                xs += x + [None]
                ys += y + [None]
            data.append(kit.line(xs, ys, f"tree: gait {j + 1}", gait_color(j), width=1.2, hoverinfo="skip"))
        data.append({"type": "scatter", "mode": "markers", "x": kit.series(pos[:, 0], digits=3),
                     "y": kit.series(pos[:, 1], digits=3), "name": f"tree nodes ({len(pos)})",
                     "marker": {"size": 4, "color": "#18202b"}, "hovertemplate": "node (%{x:.1f}, %{y:.1f}) mu<extra></extra>"})
        path = plan_nodes(tree)
        if len(path) > 1:
            xs, ys = [], []
            for i in path[1:]:
                x, y = _xy_of_edge(tree, i)
                xs += x
                ys += y
            data.append(kit.line(xs, ys, plan_label([int(tree["gait"][i]) + 1 for i in path[1:]]), "#111827",
                                 width=4, hoverinfo="skip"))
    plan = traces.get("plan") if hasattr(traces, "get") else None
    if plan is not None and "pivot_mu" in plan and len(plan["pivot_mu"]) > 1:
        p = np.asarray(plan["pivot_mu"], dtype=float)
        step = kit.stride(len(p), 600)
        data.append(kit.line(kit.series(p[:, 0], step, digits=3), kit.series(p[:, 1], step, digits=3),
                             "plan replayed in full simulation", "#f59e0b", dash="dot", width=2.5, visible="legendonly"))
    sx, sy = pm["start"][:2]
    data.append({"type": "scatter", "mode": "markers+text", "x": [sx], "y": [sy], "name": "start", "text": ["start"],
                 "textposition": "bottom center", "marker": {"symbol": "circle", "size": 14, "color": "#facc15",
                                                             "line": {"color": "#18202b", "width": 2}}})
    if summary.get("cost") == "distance" or not pm.get("flat", True):
        gx, gy = pm["goal"][:2]
        data.append({"type": "scatter", "mode": "markers+text", "x": [gx], "y": [gy], "name": "goal", "text": ["goal"],
                     "textposition": "top center", "marker": {"symbol": "star", "size": 18, "color": "#dc2626",
                                                              "line": {"color": "#18202b", "width": 1.5}}})
    layout = {"xaxis": kit.axis("x (mu)", range=[-0.5, W + 0.5], constrain="domain"),
              "yaxis": kit.axis("y (mu)", range=[-0.5, H + 0.5], scaleanchor="x", scaleratio=1),
              "shapes": shapes, "hovermode": "closest",
              # the legend above the map, not beside it: beside it, it left a phone's map 60 px wide
              "legend": {"orientation": "h", "x": 0, "y": 1.02, "yanchor": "bottom"}, "margin": {"l": 56, "r": 8, "t": 24, "b": 44}}
    res = summary.get("result", {})
    what = (f"coverage {res.get('final_best', 0):.1f} % of cells" if summary.get("cost") == "coverage"
            else f"distance to the goal {res.get('final_best', 0):.2f} mu")
    cap = (f"RRT-MP tree (Alg. 1) of the best gait set on the '{pm.get('name')}' map ({W:g} × {H:g} mu, 1 mu = one module): "
           f"{what}. Edges are the swept paths, coloured by the gait that made them; dark rectangles are obstacles, grey "
           "boxes raised terrain; green cells hold a tree node. The thick line is the final plan"
           + (" (the longest branch: a coverage run has no goal)" if summary.get("cost") == "coverage" else " to the goal") + ".")
    return kit.panel("map", "Map, tree and plan", cap, kit.figure(data, layout), height=560)


def gait_traces_view(summary: dict, traces: Mapping) -> dict | None:
    data = []
    j = 0
    while f"gait{j + 1}" in traces:
        p = np.asarray(traces[f"gait{j + 1}"]["pivot_mu"], dtype=float)
        xy = p[:, :2] - p[0, :2]
        step = kit.stride(len(xy), 400)
        data.append(kit.line(kit.series(xy[:, 0], step, digits=3), kit.series(xy[:, 1], step, digits=3),
                             f"gait {j + 1}", gait_color(j), width=2.5))
        data.append({"type": "scatter", "mode": "markers", "x": [float(xy[-1, 0])], "y": [float(xy[-1, 1])],
                     "marker": {"color": gait_color(j), "size": 9}, "showlegend": False, "name": f"gait {j + 1} end"})
        j += 1
    if not data:
        return None
    layout = {"xaxis": kit.axis("x (mu), robot starts facing +x"), "yaxis": kit.axis("y (mu)", scaleanchor="x", scaleratio=1),
              "hovermode": "closest"}
    cap = "Top view of the pivot module during one execution of each evolved gait, from the same start (Figs. 4-5)."
    return kit.panel("gait-traces", "Evolved gaits, top view", cap, kit.figure(data, layout), height=420)


def per_gait_table(summary: dict) -> dict | None:
    pg = summary.get("per_gait") or []
    if not pg:
        return None
    rows = [[f"gait {r['gait']}", r.get("distance_mu"), r.get("rotation_deg"),
             ", ".join(f"{v:.2f}" for v in r.get("end_mu", []))] for r in pg]
    cap = f"One execution of each gait ({summary.get('gaits')} gaits evolved together): travelled distance and rotation (Fig. 7)."
    return kit.panel("per-gait", "Per-gait trials", cap,
                     table=kit.table(["gait", "distance (mu)", "rotation (°)", "end point (mu)"], rows))


def reuse_view(summary: dict) -> list[dict]:
    r = summary.get("reuse")
    if not r:
        return []
    names = list(r)
    rows = [[n.replace("_", " "), f"{r[n]['distance_mu']['mean']:.2f} ± {r[n]['distance_mu']['std']:.2f}",
             f"{r[n]['coverage_pct']['mean']:.1f} ± {r[n]['coverage_pct']['std']:.1f}"] for n in names]
    tab = kit.panel("reuse-table", "Reuse of the evolved gaits", "Sec. V-C: the gaits planned again to a goal 30 mu away on "
                    "new maps (mean ± std over the plans; distance lower is better, coverage higher is better).",
                    table=kit.table(["scenario", "distance to goal (mu, lower better)", "coverage (%, higher better)"], rows))
    # two-line labels: on a phone plotly rotated "column opposite" over the axis title
    data = [{"type": "bar", "x": [n.replace("_", "<br>") for n in names], "y": [r[n]["distance_mu"]["mean"] for n in names],
             "error_y": {"type": "data", "array": [r[n]["distance_mu"]["std"] for n in names]}, "name": "distance to goal (mu)",
             "marker": {"color": kit.METHOD}}]
    fig = kit.panel("reuse", "Reuse: distance to goal per scenario", "Lower is better; error bars one standard deviation.",
                    kit.figure(data, {"xaxis": {**kit.axis("scenario", automargin=True),
                                                "title": {"text": "scenario", "standoff": 8}},
                                      "yaxis": kit.axis("distance to goal (mu)", automargin=True),
                                      "hovermode": "closest"}), height=320)
    return [tab, fig]


def composition_view(traces: Mapping) -> dict | None:
    tr = traces.get("composition") if hasattr(traces, "get") else None
    if tr is None or "depth" not in tr:
        return None
    c, s, d = (np.asarray(tr[k], dtype=float) for k in ("composed_mu", "simulated_mu", "depth"))
    if len(d) < 2:
        return None
    err = np.linalg.norm(c[1:, :2] - s[1:, :2], axis=1)
    data = [{"type": "scatter", "mode": "markers", "x": kit.series(d[1:], digits=0), "y": kit.series(err, digits=4),
             "name": "tree node", "marker": {"color": kit.METHOD, "size": 7, "opacity": 0.7},
             "hovertemplate": "depth %{x}: %{y:.3f} mu<extra></extra>"}]
    layout = {"xaxis": kit.axis("node depth (gaits from the root)", dtick=1), "yaxis": kit.axis("position error (mu)"),
              "hovermode": "closest"}
    cap = ("The planner composes gait primitives instead of simulating every branch; these nodes were replayed in full "
           "simulation. Error of the composed position against node depth.")
    return kit.panel("composition", "Composed vs simulated tree nodes", cap, kit.figure(data, layout), height=320)


def views(summary: dict, traces: Mapping) -> list[dict]:
    out = [map_view(summary, traces)]
    out += [v for v in (per_gait_table(summary), gait_traces_view(summary, traces)) if v]
    out += reuse_view(summary)
    c = composition_view(traces)
    if c:
        out.append(c)
    return out


# form groups the dashboard opens first: shape (robot), stuck modules, map, cost, budget
FORM_OPEN = ["damage", "search"]

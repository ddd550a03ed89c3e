"""Dashboard views of the recovery kind (paper 000): Table II's before/after row with the
walking target marked met or not and every value marked better or worse than the baseline;
body roll, pitch, yaw and the CoM against time (Figs. 4-5); the gait diagram per leg."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from app.jobs import viewkit as kit
from app.jobs.recovery.metrics import basis_text, judged, target_checks, target_met, target_text_of, walk_of
from app.jobs.recovery.gaitplan import GAIT_SCHEME, faded, plan_of, planned_swings
from app.jobs.recovery.present import met_word, replay_style

# labels and colours as the replay shows them (present.replay_style, app/core/colors.py roles)
RUNS = {t.name: (t.label, t.color) for t in replay_style(["best", "baseline"])}


def _order(traces: Mapping) -> list[str]:
    return [n for n in ("baseline", "best") if n in traces] + [n for n in traces if n not in RUNS]


def _style(name: str, i: int) -> tuple[str, str]:
    return RUNS.get(name, (name.replace("_", " "), kit.PALETTE[(i + 2) % len(kit.PALETTE)]))


def table_two(summary: dict) -> dict | None:
    best, base = summary.get("best"), summary.get("baseline")
    if not best or not base:
        return None
    cols = [("lateral x (cm)", lambda m: m["x_f_m"] * 100, "absmin", "lateral"),
            ("forward y (cm)", lambda m: m["y_f_m"] * 100, "max", "forward"),
            ("final yaw (°)", lambda m: m["yaw_f_deg"], "absmin", "yaw"),
            ("roll amplitude (°)", lambda m: m["roll_amp_deg"], "min", None),
            ("pitch amplitude (°)", lambda m: m["pitch_amp_deg"], "min", None)]

    def better(kind, a, b):
        if kind == "max":
            return b > a
        if kind == "min":
            return b < a
        return abs(b) < abs(a)

    walk = walk_of(summary)  # the target scales with the walk's length (metrics.target_for)
    tgt = target_text_of(summary)
    rows = []
    for name, r in (("baseline", base), ("best", best)):
        m = r["metrics"]
        checks: dict = target_checks(m, walk) if judged(walk) else {"forward": None, "lateral": None, "yaw": None,
                                                                    "upright": False if m["fell"] else None}
        row: list = [RUNS[name][0]]
        for _, f, kind, tkey in cols:
            v = f(m)
            b = None if name == "baseline" or f(base["metrics"]) == v else better(kind, f(base["metrics"]), v)
            row.append(kit.cell(round(v, 2), met=checks[tkey] if tkey else None, better=b))
        row.append(kit.cell("yes" if m["fell"] else "no", met=checks["upright"]))
        fb = None if name == "baseline" or r["fitness"] == base["fitness"] else r["fitness"] > base["fitness"]
        row.append(kit.cell(r["fitness"], better=fb))
        ok = target_met(m, walk)
        row.append(kit.cell(met_word(ok), met=ok))
        rows.append(row)
    cap = (f"As in the paper's Table II: final position (x sideways drift, y forward, the walking direction), final yaw, "
           f"roll and pitch amplitude; F is the fitness of Eq. 5 (higher is better). Target: {tgt}; scaled to the walk: "
           f"{basis_text(walk)} — each "
           "target column says met or not met. Recovered values say better or worse than the baseline."
           + _search_note(summary))
    return kit.panel("table2", "Before and after", cap,
                     table=kit.table(["gait"] + [c[0] for c in cols] + ["fell", "F (higher better)", f"target ({tgt})"],
                                     rows))


def _search_note(summary: dict) -> str:
    """How the search ended, and its time to the target when it stopped there."""
    search, timing = summary.get("search") or {}, summary.get("timing") or {}
    if "stop_reason" not in search:
        return ""
    note = f" The search ran {search.get('generations_run')} generations (stop: {search['stop_reason']})"
    ttt = timing.get("time_to_target_s")
    if ttt is not None:
        note += (f"; it met the target, confirmed at half the step, in generation {search.get('target_generation')} "
                 f"after {ttt:.1f} s ({search.get('evaluations_to_target')} evaluations)")
    return note + "."


def _stack_view(pid: str, title: str, traces: Mapping, specs: list[tuple], unit: str, caption: str) -> dict | None:
    names = _order(traces)
    present = [s for s in specs if any(s[0](traces[n]) is not None for n in names)]
    if not present:
        return None
    doms = kit.stacked(len(present))
    data, layout = [], {"hovermode": "x unified"}
    for p, (get, label, scale) in enumerate(present):
        ax = "" if p == 0 else str(p + 1)
        for i, name in enumerate(names):
            y = get(traces[name])
            if y is None:
                continue
            t = np.asarray(traces[name]["time_s"], dtype=float)
            step = kit.stride(len(t), 800)
            nice, color = _style(name, i)
            data.append(kit.line(kit.series(t, step, digits=3), kit.series(y, step, scale=scale, digits=3), nice, color,
                                 legendgroup=name, showlegend=p == 0, xaxis=f"x{ax}", yaxis=f"y{ax}"))
        layout[f"yaxis{ax}"] = kit.axis(f"{label} ({unit})", domain=doms[p], anchor=f"x{ax}")
        layout[f"xaxis{ax}"] = kit.axis("time (s)" if p == len(present) - 1 else "", anchor=f"y{ax}",
                                        matches="x" if p else None, showticklabels=p == len(present) - 1)
    return kit.panel(pid, title, caption, kit.figure(data, layout), height=150 * len(present) + 90)


def _col(key: str, i: int | None = None):
    def get(tr):
        if key not in tr:
            return None
        a = np.asarray(tr[key], dtype=float)
        return a if i is None else a[:, i]
    return get


def _gait_bars(t: np.ndarray, contact: np.ndarray, legs: list[int], short: str, plan) -> tuple[dict, ...]:
    """Measured swing and support and planned swing bars of one trace, one row per leg."""
    bars = {k: {"x": [], "base": [], "y": [], "text": []} for k in ("swing", "support", "plan")}

    def add(kind, y, a, b, what):
        d = bars[kind]
        d["base"].append(a); d["x"].append(b - a); d["y"].append(y); d["text"].append(f"{what} {a:.2f}–{b:.2f} s")

    T = float(t[-1]) if len(t) else 0.0
    for k, leg in enumerate(legs):
        y, t0 = f"{short} · leg {leg}", float(t[0]) if len(t) else 0.0
        for s, e in kit.swing_intervals(t, contact[:, k]):
            if s > t0:
                add("support", y, t0, s, "on the ground")
            add("swing", y, s, e, "in the air")
            t0 = e
        if t0 < T:
            add("support", y, t0, T, "on the ground")
        if plan[0] is not None:
            for s, e in planned_swings(plan[0], plan[1], leg, T):
                add("plan", y, s, e, "planned swing")
    return bars["swing"], bars["support"], bars["plan"]


def gait_diagram(summary: dict, traces: Mapping) -> dict | None:
    names = [n for n in _order(traces) if "foot_contact" in traces[n]]
    if not names:
        return None
    data, cats = [], []
    for i, name in enumerate(names):
        tr = traces[name]
        t = np.asarray(tr["time_s"], dtype=float)
        contact = np.asarray(tr["foot_contact"])
        legs = [int(x) for x in tr["legs"]] if "legs" in tr else list(range(1, contact.shape[1] + 1))
        nice, color = _style(name, i)
        short = {"best": "recovered", "baseline": "tripod"}.get(name, nice)
        cats += [f"{short} · leg {leg}" for leg in legs]
        sw, su, pl = _gait_bars(t, contact, legs, short, plan_of(summary, name))
        common = {"type": "bar", "orientation": "h", "textposition": "none", "hovertemplate": "%{y}: %{text}<extra></extra>",
                  "legendgroup": name}
        measured = {"offset": -0.42, "width": 0.5}  # the measured contact below, the plan above it
        data.append(common | sw | measured | {"name": f"{nice}: swing (measured)", "marker": {"color": color}})
        data.append(common | su | measured | {"name": f"{nice}: support (measured)",
                                              "marker": {"color": faded(color)}})
        if pl["x"]:
            data.append(common | pl | {"offset": 0.14, "width": 0.26, "name": f"{nice}: planned swing",
                                       "marker": {"color": GAIT_SCHEME["planned"]}})
    period = (summary.get("gait") or {}).get("period_s")
    T = max(float(np.asarray(traces[n]["time_s"])[-1]) for n in names)
    layout = {"barmode": "overlay", "hovermode": "closest", "bargap": 0.25,
              "legend": {"orientation": "h", "y": 1.02, "yanchor": "bottom", "x": 0},
              # every leg's label, also on a phone (plotly thins crowded category ticks otherwise)
              "yaxis": {"categoryorder": "array", "categoryarray": cats[::-1], "tickmode": "array", "tickvals": cats,
                        "ticktext": cats, "automargin": True, "tickfont": {"size": 11}},
              "xaxis": kit.axis("time (s)", range=[0, 4 * period] if period and T > 4 * period else [0, T])}

    def describe(g):
        return f"{g['name']} (σ = {g['sigma']}): " + " → ".join("[" + " ".join(map(str, grp)) + "]" for grp in g.get("groups", []))

    parts = []
    if summary.get("gait"):
        parts.append("Recovered: " + describe(summary["gait"]))
    if (summary.get("baseline") or {}).get("gait"):
        parts.append("Baseline: " + describe(summary["baseline"]["gait"]))
    cap = ". ".join(parts) + (". Per leg, the measured contact (dark: swing, the foot in the air; light: support) and, "
                              "just above it, the swing the gait sequence plans (grey): where a foot never leaves the "
                              "ground, the plan's swing has no dark bar under it. The bundle's gait diagrams use the "
                              "same colours. Double-click the plot for the whole walk.")
    return kit.panel("gait", "Gait diagram: planned swing and measured contact", cap, kit.figure(data, layout),
                     height=130 + 30 * len(cats))


def views(summary: dict, traces: Mapping) -> list[dict]:
    out = [table_two(summary)]
    out.append(_stack_view("orientation", "Body roll, pitch, yaw", traces,
                           [(_col("roll_deg"), "roll", 1.0), (_col("pitch_deg"), "pitch", 1.0), (_col("yaw_deg"), "yaw", 1.0)],
                           "°", "Body orientation of the recovered gait and the baseline against time (Fig. 4)."))
    out.append(_stack_view("com", "Centre of mass", traces,
                           [(_col("com_m", 0), "CoM x", 100.0), (_col("com_m", 1), "CoM y", 100.0), (_col("com_m", 2), "CoM z", 100.0)],
                           "cm", "Centre of mass against time (Fig. 5): y is the walking direction, x the sideways drift."))
    out.append(gait_diagram(summary, traces))
    return [v for v in out if v]


# The shared controls and robustness tables (app/jobs/viewkit.py) in Table II's units and words
METRIC_NAMES = {"x_f_m": ("lateral x", "cm", 100.0), "y_f_m": ("forward y", "cm", 100.0),
                "yaw_f_deg": ("final yaw", "°", 1.0), "roll_amp_deg": ("roll amplitude", "°", 1.0),
                "pitch_amp_deg": ("pitch amplitude", "°", 1.0), "tilt_max_deg": ("largest tilt", "°", 1.0),
                "under_3_feet_frac": ("time on fewer than 3 feet", "%", 100.0), "fell": ("fell", "", 1.0)}


def metric_names(summary: dict) -> dict[str, tuple[str, str, float]]:
    return dict(METRIC_NAMES)


def page_tables(summary: dict) -> list:
    """None: the page shows the CLI's before/after table as Table II (``table_two``) and the
    controls and robustness once, as the shared evidence tables in cm and degrees."""
    return []


# form groups the dashboard opens first (the damage is drawn on the robot)
FORM_OPEN = ["damage", "search", "sim"]


ATLAS_COLUMNS = 5


def _hexapod(info: dict, cx: float, cy: float, lost: set[int], scale: float) -> tuple[list, ...]:
    """Top view of the hexapod at (cx, cy): the body outline through the hips, the legs
    that remain (hip -> foot, sideways) and the lost ones (short dotted lines)."""
    hips = {int(k): v for k, v in info["hips_m"].items()}
    order = sorted(hips, key=lambda leg: np.arctan2(hips[leg][1], hips[leg][0]))
    bx = [cx + scale * hips[leg][0] for leg in order] + [cx + scale * hips[order[0]][0]]
    by = [cy + scale * hips[leg][1] for leg in order] + [cy + scale * hips[order[0]][1]]
    reach = 0.11
    legs_x, legs_y, lost_x, lost_y = [], [], [], []
    for leg, (x, y, _z) in hips.items():
        side = 1.0 if x > 0 else -1.0
        fx, fy = x + side * reach, y + 0.35 * y
        xs, ys = (lost_x, lost_y) if leg in lost else (legs_x, legs_y)
        end = 0.35 if leg in lost else 1.0
        xs += [cx + scale * x, cx + scale * (x + end * (fx - x)), None]
        ys += [cy + scale * y, cy + scale * (y + end * (fy - y)), None]
    return bx, by, legs_x, legs_y, lost_x, lost_y


def study_views(study: dict, points: list[dict]) -> list[dict]:
    """A damage atlas (points over damage.lost_legs, e.g. every feasible 1- and 2-leg loss
    x seeds) as small hexapod top views: lost legs as short dotted lines, the body coloured by the
    median recovered forward speed, an arrow to the median end point of the walk (drift),
    and the share of seeds that meet the target."""
    from app.robots.catalog import ROBOTS

    groups: dict[tuple, list[dict]] = {}
    robot = None
    for p in points:
        s = p.get("summary")
        if p["status"] != "succeeded" or not s or "lost_legs" not in p["spec"].get("damage", {}):
            continue
        d = p["spec"]["damage"]
        if d.get("locked_joints") or d.get("weak_joints"):
            continue  # the atlas is of leg losses
        robot = p["spec"]["robot"]
        m, walk = s["best"]["metrics"], p["spec"]["sim"]["duration_s"]
        groups.setdefault(tuple(sorted(d["lost_legs"])), []).append(
            {"speed": 100 * m["y_f_m"] / p["spec"]["sim"]["duration_s"], "x": 100 * m["x_f_m"], "y": 100 * m["y_f_m"],
             "yaw": m["yaw_f_deg"], "met": target_met(m, walk) is True,
             "baseline_met": target_met(s["baseline"]["metrics"], walk) is True})
    if len(groups) < 2 or robot not in ROBOTS:
        return []
    info = ROBOTS[robot].describe()
    keys = sorted(groups, key=lambda k: (len(k), k))
    med = {k: {f: float(np.median([r[f] for r in groups[k]])) for f in ("speed", "x", "y", "yaw")} for k in keys}
    speeds = [med[k]["speed"] for k in keys]
    lo, hi = min(speeds), max(speeds)
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    data, notes = [], []
    scale, cell_w, cell_h = 1.0, 0.5, 0.55
    for i, k in enumerate(keys):
        cx, cy = (i % ATLAS_COLUMNS) * cell_w, -(i // ATLAS_COLUMNS) * cell_h
        bx, by, lx, ly, sx, sy = _hexapod(info, cx, cy, set(k), scale)
        c = cmap(0.5 if hi == lo else (med[k]["speed"] - lo) / (hi - lo))
        fill = f"rgba({int(255 * c[0])},{int(255 * c[1])},{int(255 * c[2])},0.9)"
        rows = groups[k]
        label = f"leg{'s' if len(k) > 1 else ''} {', '.join(map(str, k))} lost"
        hover = (f"{label}<br>forward {med[k]['y']:.1f} cm ({med[k]['speed']:.1f} cm/s), lateral {med[k]['x']:.1f} cm, "
                 f"yaw {med[k]['yaw']:.1f}°<br>target met {sum(r['met'] for r in rows)}/{len(rows)} seeds; "
                 f"baseline {'already meets it' if any(r['baseline_met'] for r in rows) else 'does not'}")
        data.append({"type": "scatter", "mode": "lines", "x": bx, "y": by, "fill": "toself", "fillcolor": fill,
                     "line": {"color": "#333", "width": 1}, "hoverinfo": "text", "text": hover, "showlegend": False})
        data.append({"type": "scatter", "mode": "lines", "x": lx, "y": ly, "line": {"color": "#333", "width": 2},
                     "hoverinfo": "skip", "showlegend": False})
        data.append({"type": "scatter", "mode": "lines", "x": sx, "y": sy,
                     "line": {"color": "#c0392b", "width": 2, "dash": "dot"}, "hoverinfo": "skip", "showlegend": False})
        # drift: from the body centre towards the median end point, 1 m of walk = 0.15 of a cell
        ax, ay = cx + 0.15 * med[k]["x"] / 100, cy + 0.15 * med[k]["y"] / 100
        notes.append({"x": ax, "y": ay, "ax": cx, "ay": cy, "xref": "x", "yref": "y", "axref": "x", "ayref": "y",
                      "showarrow": True, "arrowhead": 2, "arrowcolor": "#111", "arrowwidth": 1.5, "text": ""})
        notes.append({"x": cx, "y": cy - 0.22, "xref": "x", "yref": "y", "showarrow": False, "font": {"size": 11},
                      "text": f"{label}<br>{med[k]['speed']:.1f} cm/s, x {med[k]['x']:+.1f} cm, "
                              f"{sum(r['met'] for r in rows)}/{len(rows)} met"})
    data.append({"type": "scatter", "mode": "markers", "x": [None], "y": [None], "showlegend": False,
                 "hoverinfo": "skip", "marker": {"color": [lo], "cmin": lo, "cmax": hi, "colorscale": "Viridis",
                                                 "showscale": True,
                                                 "colorbar": {"title": {"text": "forward speed (cm/s)"}}}})
    rows_n = -(-len(keys) // ATLAS_COLUMNS)
    layout = {"xaxis": {"visible": False, "range": [-0.3, ATLAS_COLUMNS * cell_w - 0.2]},
              "yaxis": {"visible": False, "scaleanchor": "x", "range": [-(rows_n - 1) * cell_h - 0.32, 0.25]},
              "annotations": notes, "hovermode": "closest", "margin": {"l": 10, "r": 10, "t": 10, "b": 10}}
    cap = ("Each hexapod is one damage (short red dotted lines: the lost legs), seen from above with its front up. "
           "Body colour: the median recovered forward speed over the seeds; arrow: the median end point of the "
           "walk (straight up = no drift; 1 m of walk is 0.15 of a cell); text: speed, lateral drift and the "
           "seeds meeting the target. Hover a body for yaw and whether the nominal tripod already meets the target.")
    return [kit.panel("atlas", "Damage atlas: recovered speed and drift per leg loss", cap,
                      kit.figure(data, layout), height=max(320, 190 * rows_n))]

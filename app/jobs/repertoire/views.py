"""The repertoire's job page: the map (2-D slices of the descriptor, coloured by forward
distance, the elites that have a replay ringed), the elites to replay, MAP-Elites against
the random control, and the best elites; on a study of islands, the merged map."""

from __future__ import annotations

import numpy as np

from app.jobs import viewkit as vk
from app.jobs.repertoire.evaluate import slices
from app.jobs.repertoire.play import ELITE, elite_name

MAX_POINTS = 5000  # the page draws at most this many elites per slice (the best ones)
ROW_PX = 300  # height of one row of slices
REPLAY_RING = "#d62728"


def views(summary: dict, traces: dict) -> list[dict]:
    replayable = replay_cells_of(traces)
    out = [map_panel(summary["elites"], summary["descriptor"], summary["archive"], replayable),
           _replays(summary, replayable), _progress_note(summary), _top(summary)]
    return [p for p in out if p is not None]


def replay_cells_of(traces) -> list[int]:
    """The cells whose elite the bundle can replay (its ``elite_<cell>`` traces), by cell."""
    return sorted(int(n[len(ELITE):]) for n in traces if n.startswith(ELITE) and n[len(ELITE):].isdigit())


def map_panel(e: dict, d: dict, a: dict, replayable: list[int] = (), pid: str = "map", title: str = "The map",
              note: str = "") -> dict:
    """The elites ``e`` (archive.table's columns) in 2-D slices of the descriptor ``d``, two
    slices a row, coloured by forward distance; the ``replayable`` cells ringed."""
    pairs = slices(len(d["names"]))
    n = len(e["cell"])
    obj = np.asarray(e["objective"], dtype=float)
    meas = np.asarray(e["measures"], dtype=float).reshape(n, -1)
    keep = np.argsort(obj, kind="stable")[-MAX_POINTS:]  # ascending: the best drawn last, on top
    ring = np.array([i for i in range(n) if e["cell"][i] in set(replayable)], dtype=int)
    cols = 1 if len(pairs) == 1 else 2
    rows = -(-len(pairs) // cols)
    data, layout = [], {"height": 120 + ROW_PX * rows, "margin": {"t": 20, "l": 50, "r": 10, "b": 110},
                        "showlegend": False}
    for k, (i, j) in enumerate(pairs):
        ax = "" if k == 0 else str(k + 1)
        r, c = divmod(k, cols)
        data.append({"type": "scattergl", "mode": "markers", "xaxis": f"x{ax}", "yaxis": f"y{ax}",
                     "x": vk.series(meas[keep, i]), "y": vk.series(meas[keep, j]),
                     "text": [f"cell {e['cell'][q]}" for q in keep],
                     "marker": {"color": vk.series(obj[keep]), "colorscale": "Viridis", "size": 5,
                                "showscale": k == len(pairs) - 1,
                                "colorbar": {"title": {"text": "forward (m)", "side": "top"}, "thickness": 10,
                                             "orientation": "h", "x": 0.5, "xanchor": "center", "len": 0.7,
                                             "y": -0.25 / rows, "yanchor": "top"}},
                     "name": "elites", "hovertemplate": "%{text}<br>forward %{marker.color:.3f} m<extra></extra>"})
        if len(ring):
            data.append({"type": "scatter", "mode": "markers", "xaxis": f"x{ax}", "yaxis": f"y{ax}",
                         "x": vk.series(meas[ring, i]), "y": vk.series(meas[ring, j]),
                         "text": [f"cell {e['cell'][q]}: replay with the button 'elite of cell {e['cell'][q]}'"
                                  for q in ring],
                         "marker": {"symbol": "circle-open", "size": 11, "color": REPLAY_RING, "line": {"width": 2}},
                         "name": "has a replay", "hovertemplate": "%{text}<extra></extra>"})
        top, bottom = 1 - r / rows, 1 - (r + 1) / rows
        layout[f"xaxis{ax}"] = vk.axis(d["names"][i], domain=[c / cols + (0.09 if c else 0.0), (c + 1) / cols - (0.0 if c else 0.03)],
                                       range=list(d["bounds"][i]), anchor=f"y{ax}")
        layout[f"yaxis{ax}"] = vk.axis(d["names"][j], domain=[bottom + 0.2 / rows, top - 0.02 / rows],
                                       range=list(d["bounds"][j]), anchor=f"x{ax}")
    cap = (f"{n} elites in {a['cells']} cells ({100 * a['coverage']:.1f} % covered); each dot is a gait at its "
           f"behaviour descriptor ({', '.join(d['names'])}), shown in {len(pairs)} two-dimensional slice"
           f"{'s' if len(pairs) > 1 else ''}, coloured by its forward distance (m)")
    if len(ring):
        cap += f"; the {len(ring)} ringed elites have a replay (the 3D replay's buttons, listed below)"
    return vk.panel(pid, title, cap + (f". {note}" if note else ""), figure=vk.figure(data, layout))


def _replays(s: dict, cells: list[int]) -> dict | None:
    if not cells:
        return None
    e = s["elites"]
    row = {c: i for i, c in enumerate(e["cell"])}
    order = sorted((c for c in cells if c in row), key=lambda c: (-e["objective"][row[c]], c))
    rows = [[f"elite of cell {c}", vk.cell(e["objective"][row[c]], "m"), vk.cell(e["lateral_m"][row[c]], "m"),
             vk.cell(e["yaw_deg"][row[c]], "deg"), " ".join(f"{v:.2f}" for v in e["measures"][row[c]]),
             f"trajectories/{elite_name(c)}.npz"] for c in order]
    return vk.panel("replays", "Elites to replay",
                    "the ringed elites of the map; the 3D replay below has a button for each (its name in the first "
                    "column): the best half of them and the rest spread over the map",
                    table=vk.table(["replay", "forward", "lateral", "yaw", "descriptor", "trace"], rows))


def _progress_note(s: dict) -> dict | None:
    """Coverage and QD-score over evaluations are drawn from history.csv by the page
    (``history_axis``: QD-score) and in the bundle's ``plots/progress`` (both); this table
    states the final numbers beside the control's."""
    from app.jobs.repertoire.present import _map_rows

    return vk.panel("map_vs_random", "MAP-Elites against random search (same budget)",
                    "the same number of gaits, the same archive's cells; coverage and QD-score over evaluations: the "
                    "Convergence chart (QD-score) and the bundle's figure 'progress' (both)",
                    table=vk.table(["", "MAP-Elites", "random search"], [[k, *v] for k, v in _map_rows(s)]))


def _top(s: dict) -> dict | None:
    e = s["elites"]
    if not e["cell"]:
        return None
    top = np.argsort(-np.asarray(e["objective"]), kind="stable")[:10]
    rows = [[e["cell"][i], vk.cell(e["objective"][i], "m"), vk.cell(e["lateral_m"][i], "m"),
             vk.cell(e["yaw_deg"][i], "deg"), vk.cell(e["energy_j"][i], "J"),
             " ".join(f"{v:.2f}" for v in e["measures"][i])] for i in top]
    return vk.panel("best_elites", "Best elites", "the ten gaits of the map that walk furthest forward",
                    table=vk.table(["cell", "forward", "lateral", "yaw", "energy", "descriptor"], rows))


# -- a study of islands (app/jobs/repertoire/merge.py) -------------------------------------------

def study_views(study: dict, points: list[dict]) -> list[dict]:
    """On the page of a study whose points are islands of its base spec: the merged map and
    each island's figures beside the merged ones. Other repertoire studies: nothing."""
    from app.jobs.repertoire import merge as mg

    base = study.get("base") or {}
    try:
        expected = mg.islands_study(base, len(points))["points"] if points else None
    except (ValueError, TypeError, KeyError):
        return []
    if not expected or [p.get("overrides") for p in sorted(points, key=lambda p: p["index"])] != expected:
        return []
    done = {p["index"]: p["summary"] for p in points if p.get("status") == "succeeded" and p.get("summary")}
    if not done:
        return []
    m = mg.merged_summary(base, done)
    s0 = next(iter(done.values()))
    note = (f"{len(done)} of {len(points)} islands merged" + ("" if len(done) == len(points) else " so far")
            + f" ({m['evaluations']} MAP-Elites gaits); each island's elites re-binned into the base spec's "
              f"{m['archive']['cells']} cells, island by island in index order")
    rows = [[f"island {i['index']}", i["evaluations"], i["elites"], vk.cell(100 * i["coverage"], "%"),
             vk.cell(i["qd_score"], "m"), vk.cell(i["best_forward_m"], "m")] for i in m["islands"]]
    a = m["archive"]
    rows.append(["merged", m["evaluations"], a["elites"], vk.cell(100 * a["coverage"], "%"), vk.cell(a["qd_score"], "m"),
                 vk.cell(a["best_forward_m"], "m")])
    return [map_panel(m["elites"], s0["descriptor"], a, pid="merged_map", title="The merged map", note=note),
            vk.panel("islands", "Islands and the merged map", "each island is an independent MAP-Elites run with its "
                     "own derived seed and share of the iterations",
                     table=vk.table(["", "gaits", "elites", "coverage", "QD-score", "best forward"], rows))]

"""Figures of a multigait run (paper 001): convergence (Tables I-II), gait traces (Figs. 4,
5, 8), distance and rotation per gait (Fig. 7), the tree over the map (Figs. 6, 10), the
composed-vs-simulated check and the reuse experiment (Tables III-IV)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from app.core import plots  # noqa: E402
from app.core.plots import _save  # noqa: E402

COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown"]


def convergence(history: list[dict], axis: dict, out: Path) -> list[Path]:
    """Cost per generation (Tables I-II), ``axis`` the kind's ``history_axis`` (present.history_axis):
    the page's series and labels, the search's beside its random-search control's."""
    return plots.convergence(history, axis, out, title=f"{axis['y']} per generation")


def gait_traces(traces: dict, out: Path) -> list[Path]:
    fig, ax = plt.subplots(figsize=(5, 5))
    j = 0
    while f"gait{j + 1}" in traces:
        p = traces[f"gait{j + 1}"]["pivot_mu"]
        xy = p[:, :2] - p[0, :2]
        ax.plot(xy[:, 0], xy[:, 1], color=COLOURS[j % 6])
        ax.annotate(str(j + 1), xy[-1], fontsize=12, color=COLOURS[j % 6], weight="bold")
        j += 1
    ax.annotate("", xy=(1.0, 0.0), xytext=(0.0, 0.0), arrowprops={"arrowstyle": "->", "lw": 2})
    ax.set_aspect("equal")
    ax.set_xlabel("x (mu)")
    ax.set_ylabel("y (mu)")
    ax.set_title("Pivot traces of the evolved gaits (top view)")
    ax.grid(alpha=0.3)
    return _save(fig, out, "gait_traces")


def gait_stats(per_gait: list[dict], out: Path) -> list[Path]:
    order = sorted(per_gait, key=lambda r: -r["distance_mu"])
    fig, axes = plt.subplots(1, 2, figsize=(7, 3))
    labels = [str(r["gait"]) for r in order]
    axes[0].bar(labels, [r["distance_mu"] for r in order], color="tab:blue")
    axes[0].set_ylabel("travelled distance (mu)")
    axes[1].bar(labels, [abs(r["rotation_deg"]) for r in order], color="tab:orange")
    axes[1].set_ylabel("|rotation| (deg)")
    for a in axes:
        a.set_xlabel("gait (sorted by distance)")
        a.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return _save(fig, out, "gait_distance_rotation")


def _map(ax, pmap: dict) -> None:
    ax.add_patch(Rectangle((0, 0), pmap["width_mu"], pmap["height_mu"], fill=False, lw=1.5))
    for x0, y0, x1, y1 in pmap["obstacles"]:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.3"))
    for (cx, cy, cz), (hx, hy, hz) in pmap["terrain_boxes"]:
        ax.add_patch(Rectangle((cx - hx, cy - hy), 2 * hx, 2 * hy, color=str(0.95 - 0.12 * (cz + hz)), zorder=0))
    ax.set_xlim(-0.5, pmap["width_mu"] + 0.5)
    ax.set_ylim(-0.5, pmap["height_mu"] + 0.5)
    ax.set_aspect("equal")


def tree_map(summary: dict, tree: dict, out: Path) -> list[Path]:
    pm = summary["map"]
    fig, ax = plt.subplots(figsize=(8, 5))
    _map(ax, pm)
    pos = np.asarray(tree["pos_mu"])
    cells = np.unique(np.floor(pos[:, :2] / pm["cell_mu"]).astype(int), axis=0)
    for cx, cy in cells:
        ax.add_patch(Rectangle((cx * pm["cell_mu"], cy * pm["cell_mu"]), pm["cell_mu"], pm["cell_mu"],
                               color="tab:green", alpha=0.25, lw=0))
    paths = tree.get("paths_mu")
    for i in range(1, len(pos)):
        g = int(tree["gait"][i])
        if paths is not None:
            ax.plot(paths[i, :, 0], paths[i, :, 1], color=COLOURS[g % 6], lw=0.7)
        else:
            p = int(tree["parent"][i])
            ax.plot(pos[[p, i], 0], pos[[p, i], 1], color=COLOURS[g % 6], lw=0.7)
    ax.plot(pos[:, 0], pos[:, 1], ".", ms=2, color="k")
    ax.plot(*pm["start"][:2], "o", color="gold", ms=9, mec="k", label="start")
    if summary["cost"] == "distance":
        ax.plot(*pm["goal"][:2], "*", color="red", ms=14, mec="k", label="goal")
    ax.set_title(f"RRT-MP tree, {summary['robot']} on {pm['name']}: {summary['cost']} "
                 f"{summary['result']['final_best']:.2f}")
    ax.legend(loc="upper right")
    return _save(fig, out, "tree_map")


def composition(traces: dict, summary: dict, out: Path) -> list[Path]:
    if "composition" not in traces:
        return []
    tr = traces["composition"]
    c, s, d = np.asarray(tr["composed_mu"]), np.asarray(tr["simulated_mu"]), np.asarray(tr["depth"])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    _map(axes[0], summary["map"])
    axes[0].plot(c[:, 0], c[:, 1], "o", ms=3, label="composed")
    axes[0].plot(s[:, 0], s[:, 1], "x", ms=3, label="simulated")
    for a, b in zip(c, s):
        axes[0].plot([a[0], b[0]], [a[1], b[1]], color="0.6", lw=0.5)
    axes[0].legend()
    axes[0].set_title("tree nodes: composed vs full simulation")
    err = np.linalg.norm(c[1:, :2] - s[1:, :2], axis=1)
    axes[1].plot(d[1:], err, ".", alpha=0.6)
    axes[1].set_xlabel("node depth (gaits from the root)")
    axes[1].set_ylabel("position error (mu)")
    axes[1].grid(alpha=0.3)
    fig.tight_layout()
    return _save(fig, out, "composition_error")


def reuse(summary: dict, out: Path) -> list[Path]:
    r = summary.get("reuse")
    if not r:
        return []
    names = list(r)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    for ax, key, label in ((axes[0], "distance_mu", "distance to goal (mu)"), (axes[1], "coverage_pct", "coverage (%)")):
        ax.bar(names, [r[n][key]["mean"] for n in names], yerr=[r[n][key]["std"] for n in names], color="tab:blue")
        ax.set_ylabel(label)
        ax.tick_params(axis="x", rotation=20)
        ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return _save(fig, out, "reuse")


def all_plots(result, out, axis: dict) -> list[Path]:
    """``axis``: the kind's ``history_axis``, which the convergence figure draws as the page does."""
    out = Path(out)
    s = result.summary
    files = convergence(result.history, axis, out)
    files += gait_traces(result.traces, out)
    files += gait_stats(s["per_gait"], out)
    files += tree_map(s, result.traces.get("tree", s["tree"]), out)
    files += composition(result.traces, s, out)
    files += reuse(s, out)
    return files

"""Bundle figures of the freegait kind (paper 004): the minefield top view (Fig. 9), SM and
K_R against time (Fig. 8b-c) and the support/transfer diagram (Fig. 8a), drawn from the
job page's description of the same plots (views.minefield_runs, margin_lines,
tripod_color and their names, titles and colours), so the zip and the page agree (issue 25).

The page draws the walk and its control on one map, the control behind its legend entries;
a static figure cannot hide a series until clicked, so the minefield figure draws each in
its own panel under the page's names."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.core.plots import DASHES, PX, _save, plt
from app.jobs.freegait import views as V


def _draw_zones(ax, s: dict) -> None:
    f = s["field"]
    for x, y in s.get("zones", []):
        ax.add_patch(plt.Circle((x, y), f["safe_radius_m"], color=V.SAFE, zorder=1))
        ax.add_patch(plt.Circle((x, y), f["zone_radius_m"], color=V.ZONE, zorder=2))


def _minefield_panel(ax, s: dict, run: dict) -> None:
    body, feet, bad = V.foothold_names(run["name"])
    _draw_zones(ax, s)
    if run["path"] is not None:
        ax.plot(run["path"][:, 0], run["path"][:, 1], color=run["color"], lw=1 * PX, label=body)
    ok = np.array([[r["x"], r["y"]] for r in run["ok"]]).reshape(-1, 2)
    ax.plot(ok[:, 0], ok[:, 1], "o", ms=5, mfc="none", color=run["color"], zorder=3, label=feet)
    if run["bad"]:
        xy = np.array([[r["x"], r["y"]] for r in run["bad"]])
        ax.plot(xy[:, 0], xy[:, 1], "x", ms=7, mew=2, color=V.FAILURE, zorder=4, label=bad)
    xy = np.array([[r["x"], r["y"]] for r in run["ok"] + run["bad"]]).reshape(-1, 2)
    lo = xy.min(axis=0) - 0.3 if len(xy) else np.array([-1, -1])
    hi = xy.max(axis=0) + 0.3 if len(xy) else np.array([1, 1])
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_title(f"{run['name']}: {len(run['bad'])} of {len(xy)} footholds in forbidden zones", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=7)


def minefield_figure(s: dict, traces: dict, out: Path) -> list[Path]:
    runs = V.minefield_runs(s, traces)
    fig, axes = plt.subplots(len(runs), 1, figsize=(9, 3.8 * len(runs)), squeeze=False, constrained_layout=True)
    for ax, run in zip(axes[:, 0], runs):
        _minefield_panel(ax, s, run)
    fig.suptitle(V.MINEFIELD_TITLE)
    return _save(fig, out, "minefield")


def margins_figure(s: dict, traces: dict, out: Path) -> list[Path]:
    m = V.margin_lines(s, traces)
    t = m["t"]
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for ax, (name, axis, color, width, y) in zip(axes, m["lines"]):
        ax.plot(t, y, color=color, lw=width * PX, label=name)
        ax.set_ylabel(axis)
        ax.grid(alpha=0.3)
    name, color, dash, width = V.SM_MIN
    axes[0].plot([float(t[0]), float(t[-1])], [m["sm_min"]] * 2, DASHES[dash], color=color, lw=width * PX, label=name)
    stopped, fill, opacity = V.STOPPED
    for i, (a, b) in enumerate(m["stops"]):
        for ax in axes:  # the page's shading spans both rows
            ax.axvspan(a, b, color=fill, alpha=opacity, lw=0, label=stopped if i == 0 and ax is axes[0] else f"_{stopped}")
    axes[1].axhline(0.0, color=V.ROLES["zero"], lw=PX, label="_zero")
    for ax in axes:
        ax.legend(fontsize=7, loc="upper right")
    axes[1].set_xlabel("time (s)")
    fig.suptitle(V.MARGINS_TITLE)
    return _save(fig, out, "margins")


def gait_diagram_figure(traces: dict, out: Path) -> list[Path]:
    tr = traces["walk"]
    t = np.asarray(tr["time_s"])
    ph = np.asarray(tr["phase"])
    fig, ax = plt.subplots(figsize=(8, 2.8))
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.1
    for leg in range(6):
        sup = ph[:, leg] == 0
        edges = np.flatnonzero(np.diff(np.r_[0, sup.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            ax.plot([t[a], t[b - 1] + dt], [leg + 1, leg + 1], color=V.tripod_color(leg), lw=5, solid_capstyle="butt")
    ax.set_yticks(range(1, 7))
    ax.set_yticklabels([f"leg {i}" for i in range(1, 7)])
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    ax.set_ylabel("leg")
    ax.set_title(f"{V.GAIT_TITLE}: support (bar), transfer (gap); tripod 1 (legs 1, 4, 5) blue, tripod 2 orange",
                 fontsize=9)
    return _save(fig, out, "gait_diagram")

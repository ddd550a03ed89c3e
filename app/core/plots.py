"""Shared matplotlib setup of the kinds' bundle figures (SVG + PNG); each kind draws its own
figures in its package (app/jobs/<kind>/plots.py)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from app.core.colors import history_styles  # noqa: E402

DASHES = {"solid": "-", "dot": ":", "dash": "--", "dashdot": "-."}  # plotly's dash -> matplotlib's
PX = 0.75  # matplotlib points per page pixel: a page line's width in a figure


def _save(fig, out: Path, name: str) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in ("svg", "png"):
        p = out / f"{name}.{ext}"
        fig.savefig(p, dpi=110, bbox_inches="tight")
        paths.append(p)
    plt.close(fig)
    return paths


def history_lines(ax, history: list[dict], series: dict[str, str], x: str = "generation") -> None:
    """The dashboard's convergence plot in matplotlib: each of ``series`` ({history column:
    label}, the kind's ``history_axis`` series) the history holds numbers for, in that
    order, coloured, dashed and weighted as the page draws it (colors.history_styles)."""
    def num(v) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    keys = [k for k in series if any(num(r.get(k)) for r in history)]
    for k, (color, dash, width) in history_styles(keys).items():
        pts = [(r.get(x, i), r[k]) for i, r in enumerate(history) if num(r.get(k))]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], DASHES.get(dash, "-"), color=color, lw=PX * width,
                marker="o", ms=3, label=series[k])


def axis_title(axis: dict) -> str:
    """The convergence plot's y title as the page writes it (web/static/job.js: the kind's
    ``history_axis`` y, then ", <better> better" when it says which way is better)."""
    return f"{axis['y']}, {axis['better']} better" if axis.get("better") else axis["y"]


def convergence(history: list[dict], axis: dict, out: Path, title: str = "Convergence", log: bool = False,
                empty: str = "no history") -> list[Path]:
    """The bundle's convergence figure: the page's convergence plot drawn from the same
    description, the kind's ``history_axis`` (its series and their labels, its x column, its
    y title and direction), so the figure and the page cannot name or pick different lines.
    ``log``: a log y axis; ``empty``: the note drawn when the history holds none of the series."""
    fig, ax = plt.subplots(figsize=(6, 3.5))
    x = axis.get("x") or "generation"
    history_lines(ax, history, axis["series"], x)
    if ax.get_lines():
        if log:
            ax.set_yscale("log")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, empty, ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel(x)
    ax.set_ylabel(axis_title(axis))
    ax.set_title(title)
    ax.grid(alpha=0.3)
    return _save(fig, out, "convergence")

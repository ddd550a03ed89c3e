"""Shared matplotlib setup of the kinds' bundle figures (SVG + PNG); each kind draws its own
figures in its package (app/jobs/<kind>/plots.py)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from app.core.colors import history_styles  # noqa: E402

DASHES = {"solid": "-", "dot": ":", "dash": "--"}  # plotly's dash -> matplotlib's


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
        ax.plot([p[0] for p in pts], [p[1] for p in pts], DASHES.get(dash, "-"), color=color, lw=0.75 * width,
                marker="o", ms=3, label=series[k])

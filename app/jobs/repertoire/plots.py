"""The repertoire's bundle figures: progress against the random control, and the map."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from app.core.plots import _save  # noqa: E402
from app.jobs.repertoire.evaluate import slices  # noqa: E402


def progress(history: list[dict], out: Path) -> list[Path]:
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    x = [r["evaluations"] for r in history]
    for ax, key, label in ((axes[0], "coverage", "coverage"), (axes[1], "qd_score", "QD-score (m)")):
        ax.plot(x, [r[key] for r in history], color="tab:blue", label="MAP-Elites")
        if history and f"random_{key}" in history[0]:
            ax.plot(x, [r[f"random_{key}"] for r in history], color="tab:grey", ls="--", label="random search")
        ax.set_xlabel("gaits scored")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    return _save(fig, out, "progress")


def archive(summary: dict, out: Path) -> list[Path]:
    e, d = summary["elites"], summary["descriptor"]
    pairs = slices(len(d["names"]))
    fig, axes = plt.subplots(1, len(pairs), figsize=(3.4 * len(pairs) + 0.8, 3.2), squeeze=False)
    meas = np.asarray(e["measures"], dtype=float).reshape(len(e["cell"]), -1)
    obj = np.asarray(e["objective"], dtype=float)
    order = np.argsort(obj, kind="stable")  # the best drawn last, on top
    sc = None
    for ax, (i, j) in zip(axes[0], pairs):
        if len(obj):
            sc = ax.scatter(meas[order, i], meas[order, j], c=obj[order], s=8, cmap="viridis")
        ax.set_xlabel(d["names"][i])
        ax.set_ylabel(d["names"][j])
        ax.set_xlim(*d["bounds"][i])
        ax.set_ylim(*d["bounds"][j])
        ax.grid(alpha=0.3)
    if sc is not None:
        fig.colorbar(sc, ax=axes[0].tolist(), label="forward distance (m)")
    fig.suptitle(f"{len(obj)} elites in {summary['archive']['cells']} cells")
    return _save(fig, out, "archive")

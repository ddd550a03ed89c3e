"""Bundle figures of the ``recovery`` kind (paper 000): convergence (Fig. 3), body
orientation (Fig. 4), CoM position (Fig. 5), gait diagrams."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.core import plots
from app.core.plots import _save, plt


def convergence(history: list[dict], axis: dict, out: Path) -> list[Path]:
    """Fig. 3: the page's convergence plot, ``axis`` the kind's ``history_axis`` (its series,
    labels and y title; present.history_axis)."""
    return plots.convergence(history, axis, out)


def _three_rows(traces: dict[str, dict], out: Path, style: dict[str, tuple[str, str]] | None, rows, title: str,
                name: str) -> list[Path]:
    """Three stacked time series per trace; ``rows(trace)`` gives [(values, y label)] x 3."""
    fig, axes = plt.subplots(3, 1, figsize=(6, 6), sharex=True)
    for trace_name, tr in traces.items():
        label, color = (style or {}).get(trace_name, (trace_name, None))
        for ax, (y, ylabel) in zip(axes, rows(tr)):
            ax.plot(tr["time_s"], y, label=label, color=color)
            ax.set_ylabel(ylabel)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time (s)")
    if axes[0].get_lines():  # a result without traces draws empty axes, and no empty legend
        axes[0].legend()
    for ax in axes:
        ax.grid(alpha=0.3)
    return _save(fig, out, name)


def orientation(traces: dict[str, dict], out: Path, style: dict[str, tuple[str, str]] | None = None) -> list[Path]:
    """``style``: trace name -> (label, colour), the replay's (app/core/colors.py)."""
    return _three_rows(traces, out, style,
                       lambda tr: [(tr[k], k.replace("_deg", " (deg)")) for k in ("roll_deg", "pitch_deg", "yaw_deg")],
                       "Body orientation (ZYX; roll about y, pitch about x)", "orientation")


def com_position(traces: dict[str, dict], out: Path, style: dict[str, tuple[str, str]] | None = None) -> list[Path]:
    return _three_rows(traces, out, style,
                       lambda tr: [(np.asarray(tr["com_m"])[:, i], f"CoM {'xyz'[i]} (m)") for i in range(3)],
                       "Centre of mass (forward is +y)", "com")


def gait_diagram(trace: dict, out: Path, name: str = "gait_diagram", seconds: float = 2.4, color: str | None = None,
                 plan: tuple[dict | None, float | None] = (None, None)) -> list[Path]:
    """Per leg, the measured contact (swing: the run's ``color``; support: the same, faded)
    and the planned swing of ``plan`` (gait sequence, period) beside it, in the page's
    colour scheme (views.GAIT_SCHEME)."""
    from app.core.colors import ROLES
    from app.jobs.recovery.gaitplan import GAIT_SCHEME, planned_swings

    color = color or ROLES["method"]
    t = np.asarray(trace["time_s"])
    contact = np.asarray(trace["foot_contact"]).astype(bool)
    legs = [int(x) for x in trace["legs"]]
    sel = (t >= 0) & (t <= seconds)
    fig, ax = plt.subplots(figsize=(6, 0.55 * len(legs) + 1.3))
    for i, leg in enumerate(legs):
        y = len(legs) - 1 - i  # leg order top to bottom, as on the page
        c = contact[sel, i]
        ax.fill_between(t[sel], y - 0.42, y + 0.08, where=c, step="post", color=color, alpha=GAIT_SCHEME["support_alpha"],
                        linewidth=0, label="support (measured)" if i == 0 else None)
        ax.fill_between(t[sel], y - 0.42, y + 0.08, where=~c, step="post", color=color, linewidth=0,
                        label="swing (measured)" if i == 0 else None)
        if plan[0] is not None:
            for k, (a, b) in enumerate(planned_swings(plan[0], plan[1], leg, float(t[sel][-1]) if sel.any() else 0.0)):
                ax.fill_between([a, b], y + 0.14, y + 0.40, color=GAIT_SCHEME["planned"], linewidth=0,
                                label="planned swing" if i == 0 and k == 0 else None)
    ax.set_yticks(range(len(legs)), [f"leg {l}" for l in reversed(legs)])
    ax.set_xlabel("time (s)")
    ax.set_title("Gait diagram: planned swing (grey) above the measured contact")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=3, frameon=False, fontsize=8)
    return _save(fig, out, name)

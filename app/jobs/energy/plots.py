"""Figures of an ``energy`` job (matplotlib, SVG + PNG), like paper 003's Figs. 3-4."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.core import plots
from app.core.plots import _save, plt
from app.robots.quadruped import LEGS

from app.core.colors import hex_color  # noqa: E402

NLP_STYLE = dict(color=hex_color("baseline"), lw=1.2, ls="--", label="NLP (SRB + dummy legs)")
FINAL_STYLE = dict(color=hex_color("method"), lw=1.8, label="final (QP)")
FWD_STYLE = dict(color=hex_color("reference"), lw=1.2, label="NLP forces in the full equations")


def _finish(fig, axes, title: str, out: Path, stem: str) -> list[Path]:
    """A grid of panels over time: the time axis on the bottom row, the legend in the first panel."""
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title)
    return _save(fig, out, stem)


def forces(traces: dict, out: Path) -> list[Path]:
    """Fig. 3: contact forces per leg and axis, NLP against the final (QP) solution."""
    f = traces["forces"]
    t = np.asarray(f["time_s"])
    fn, fq = np.asarray(f["f_nlp"]).reshape(len(t), 4, 3), np.asarray(f["f_qp"]).reshape(len(t), 4, 3)
    fig, axes = plt.subplots(3, 4, figsize=(12, 6.5), sharex=True)
    for i, leg in enumerate(LEGS):
        for a, name in enumerate(("F_x", "F_y", "F_z")):
            ax = axes[a, i]
            ax.plot(t, fn[:, i, a], **NLP_STYLE)
            ax.plot(t, fq[:, i, a], **FINAL_STYLE)
            ax.grid(alpha=0.3)
            if i == 0:
                ax.set_ylabel(f"{name} (N)")
            if a == 0:
                ax.set_title(leg)
    return _finish(fig, axes, "Contact forces per leg (Fig. 3); NLP dashed, final solid", out, "forces")


def wrench(traces: dict, out: Path) -> list[Path]:
    """Fig. 3's moments: the contacts' total force and moment on the trunk, and the
    residual of the full equations (eps) per stage."""
    f = traces["forces"]
    t = np.asarray(f["time_s"])
    wn, wq = np.asarray(f["wrench_nlp"]), np.asarray(f["wrench_qp"])
    en, eq = np.asarray(f["eps_nlp"]), np.asarray(f["eps_qp"])
    names = ("F_x (N)", "F_y (N)", "F_z (N)", "M_x (N m)", "M_y (N m)", "M_z (N m)")
    fig, axes = plt.subplots(2, 6, figsize=(15, 5), sharex=True)
    for j in range(6):
        axes[0, j].plot(t, wn[:, j], **NLP_STYLE)
        axes[0, j].plot(t, wq[:, j], **FINAL_STYLE)
        axes[0, j].set_title(names[j], fontsize=9)
        axes[1, j].plot(t, en[:, j], color=hex_color("baseline"), lw=1.0, label="eps NLP (first pass)")
        axes[1, j].plot(t, eq[:, j], color=hex_color("method"), lw=1.4, label="eps QP")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
        axes[1, j].set_xlabel("t (s)")
    axes[0, 0].set_ylabel("contact wrench")
    axes[1, 0].set_ylabel("residual (Eq. 9)")
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle("Contact wrench on the trunk and the residual of the full equations")
    return _save(fig, out, "wrench")


def body(traces: dict, speed: float, out: Path) -> list[Path]:
    """Fig. 4: trunk motion, NLP against the forward integration with the NLP forces and
    with the final (QP) forces."""
    b = traces["body"]
    t = np.asarray(b["time_s"])
    labels = ("x - V t (m)", "y (m)", "z (m)", "roll (rad)", "pitch (rad)", "yaw (rad)")
    fig, axes = plt.subplots(2, 3, figsize=(12, 5.5), sharex=True)
    for j, ax in enumerate(axes.ravel()):
        for key, style in (("nlp", NLP_STYLE), ("forward_nlp", FWD_STYLE), ("final", FINAL_STYLE)):
            r, th = np.asarray(b[f"{key}_r"]), np.asarray(b[f"{key}_theta"])
            y = (r[:, 0] - speed * t) if j == 0 else (r[:, j] if j < 3 else th[:, j - 3])
            ax.plot(t, y, **style)
        ax.set_ylabel(labels[j])
        ax.grid(alpha=0.3)
    return _finish(fig, axes, "Trunk motion over one period (Fig. 4)", out, "body_motion")


def gait_diagram(summary: dict, out: Path) -> list[Path]:
    g = summary["gait"]
    T = g["period_s"]
    fig, ax = plt.subplots(figsize=(7, 2.4))
    for i, leg in enumerate(g["legs"]):
        t0, dur = g["touchdown_s"][i], g["duty"][i] * T
        for start in (t0 - T, t0, t0 + T):
            a, b = max(start, 0.0), min(start + dur, 2 * T)
            if b > a:
                ax.broken_barh([(a, b - a)], (i - 0.35, 0.7), color=hex_color("support"))
    ax.set_yticks(range(len(g["legs"])), g["legs"])
    ax.set_xlim(0, 2 * T)
    ax.axvline(T, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("t (s); bars = contact")
    ax.set_title(f"Gait diagram: T = {T:.3f} s, duty {', '.join(f'{d:.2f}' for d in g['duty'])}")
    ax.invert_yaxis()
    return _save(fig, out, "gait_diagram")


def convergence(history: list[dict], axis: dict, out: Path) -> list[Path]:
    """J per generation, ``axis`` the kind's ``history_axis`` (present.history_axis: the
    page's series, labels and y title), on a log axis (infeasible candidates carry a
    penalty >= 1e4)."""
    return plots.convergence(history, axis, out, log=True, empty="no search (search.optimizer = none)")


def residuals(summary: dict, out: Path) -> list[Path]:
    eps = summary.get("eps")
    if not eps:
        return []
    axes_names = ("x", "y", "z", "roll", "pitch", "yaw")
    stages = [s for s in ("nlp", "nlp_iterated", "qp", "final") if s in eps]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    w = 0.8 / len(stages)
    for k, s in enumerate(stages):
        ax.bar(np.arange(6) + k * w, [max(eps[s][a], 1e-9) for a in axes_names], w, label=s)
    ax.set_xticks(np.arange(6) + 0.4 - w / 2, axes_names)
    ax.set_yscale("log")
    ax.set_ylabel("RMS residual (N, N m)")
    ax.set_title("Residual of the full equations per stage (Eq. 9)")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8)
    return _save(fig, out, "residuals")


def physics(traces: dict, speed: float, out: Path) -> list[Path]:
    p = traces.get("physics")
    if p is None:
        return []
    t, q = np.asarray(p["time_s"]), np.asarray(p["qpos"])
    fig, axes = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
    axes[0].plot(t, q[:, 0] - speed * t)
    axes[0].set_ylabel("x - V t (m)")
    axes[1].plot(t, q[:, 2])
    axes[1].set_ylabel("trunk height (m)")
    axes[1].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title("The gait in full MuJoCo physics")
    return _save(fig, out, "physics")


def all_plots(result, out: Path, axis: dict) -> list[Path]:
    """``axis``: the kind's ``history_axis``, which the convergence figure draws as the page does."""
    s, tr = result.summary, result.traces
    speed = s["task"]["speed_m_s"]
    files = gait_diagram(s, out) + convergence(result.history, axis, out) + residuals(s, out)
    if "forces" in tr:
        files += forces(tr, out) + wrench(tr, out) + body(tr, speed, out)
    files += physics(tr, speed, out)
    return files

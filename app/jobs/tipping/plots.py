"""Bundle figures of the tipping kind (paper 002 Figs. 5-6): margin timeline with the
threshold, detection and landing, SSM / NESM and the critical edge; foot normal forces per
leg with the QP's; platform and body tilt; the recovery success rate per tilt direction.

The first three draw the job page's panels from the same description (views.margin_runs,
margin_events, force_runs, tilt_lines and their titles and colours), so the figures and the
page name, colour, clip and cut the same lines (issue 25). The page keeps SSM and NESM behind
their legend entries on a right-hand axis; a figure cannot hide a line until clicked, so it
draws them in a row of their own between the FASM and the critical edge."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from app.core.colors import ROLES  # noqa: E402
from app.core.plots import DASHES, PX, _save  # noqa: E402
from app.jobs.tipping import views as V  # noqa: E402


def _events(ax, summary: dict) -> None:
    """The page's vertical lines (detection, landings), each with its text at the top."""
    for x, text, color, dash in V.margin_events(summary):
        ax.axvline(x, color=color, ls=DASHES[dash], lw=1.5 * PX, label=f"_{text}")
        top = dash != V.LANDED[1]
        ax.text(x, 1.0 if top else 0.97, text, color=color, fontsize=7, ha="center", va="bottom" if top else "top",
                transform=ax.get_xaxis_transform())


def margin_timeline(traces: dict, summary: dict, out: Path) -> list[Path]:
    fig, (ax, ax2, ax3) = plt.subplots(3, 1, figsize=(7, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1.1, 1.1]})
    thr = float(summary.get("threshold_deg", 20.0))
    codes: dict[str, int] = {}
    for r in V.margin_runs(summary, traces):
        color, label = r["color"], r["label"]
        ax.plot(r["t"], r["fasm"], color=color, lw=2 * PX, label=f"FASM {label}")
        for nice, (v, dash) in r["extra"].items():
            ax2.plot(r["t"], v, DASHES[dash], color=color, lw=1.5 * PX, label=f"{nice} {label} (m)")
        for n in r["edges"]:
            codes.setdefault(n, len(codes))
        if r["edges"]:
            ax3.plot(r["t"], [codes[n] for n in r["edges"]], "o", ms=1.5, mew=0, color=color, label=f"_critical edge {label}")
        if r["tipped_at_s"] is not None:
            ax.plot([r["tipped_at_s"]], [V.CLIP[0]], "x", ms=10, mew=2, color=color, label=f"tipped over ({label})")
    ax.plot(V.threshold_span(traces), [thr, thr], "--", color=ROLES["threshold"], lw=2 * PX, label=V.threshold_label(thr))
    ax.axhline(0.0, color=ROLES["zero"], lw=PX, label="_zero")
    _events(ax, summary)
    ax.set_ylim(V.CLIP[0] - 5, V.CLIP[1])
    ax3.set_yticks(range(len(codes)), list(codes))
    for a, title in zip((ax, ax2, ax3), V.MARGIN_AXES):
        a.set_ylabel(title)
        a.grid(alpha=0.3)
    ax.set_title(V.MARGIN_TITLE, pad=14)
    ax.legend(fontsize=7, loc="lower left")
    if ax2.get_lines():
        ax2.legend(fontsize=6, ncol=2, loc="best")
    ax3.set_xlabel(V.TIME)
    return _save(fig, out, "margin_timeline")


def foot_forces(traces: dict, out: Path) -> list[Path]:
    runs = V.force_runs(traces)
    fig, axes = plt.subplots(max(len(runs), 1), 1, figsize=(7, 2.8 * max(len(runs), 1)), sharex=True, squeeze=False)
    for p, (ax, r) in enumerate(zip(axes[:, 0], runs)):
        for leg in range(r["fz"].shape[1]):
            color, dash, width = V.leg_line(leg)
            ax.plot(r["t"], r["fz"][:, leg], DASHES[dash], color=color, lw=width * PX,
                    label=f"leg {leg + 1}" if p == 0 else f"_leg {leg + 1}")
            if leg in r["qp"]:
                ax.plot(r["t"], r["qp"][leg], DASHES[V.QP_LINE[0]], color=color, lw=V.QP_LINE[1] * PX,
                        label=f"_leg {leg + 1}: QP")
        ax.set_ylabel(V.force_axis(r["label"]))
        ax.set_title(r["title"], fontsize=9, loc="left", fontweight="bold")
        ax.grid(alpha=0.3)
    if runs:
        axes[0, 0].legend(fontsize=7, ncol=6)
    fig.suptitle(V.FORCES_TITLE)
    axes[-1, 0].set_xlabel(V.TIME)
    return _save(fig, out, "foot_forces")


def tilt(traces: dict, out: Path) -> list[Path]:
    fig, ax = plt.subplots(figsize=(7, 3))
    for ln in V.tilt_lines(traces):
        ax.plot(ln["t"], ln["y"], DASHES[ln["dash"]], color=ln["color"], lw=2 * PX, label=ln["name"])
    ax.set_xlabel(V.TIME)
    ax.set_ylabel(V.TILT_AXIS)
    ax.set_title(V.TILT_TITLE)
    ax.grid(alpha=0.3)
    if ax.get_lines():
        ax.legend(fontsize=8)
    return _save(fig, out, "tilt")


def sweep(sw: dict, out: Path) -> list[Path]:
    th = np.radians(sw["directions_deg"])
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="polar")
    width = 2 * np.pi / max(len(th), 1) * 0.8
    ax.bar(th, [v or 0.0 for v in sw["success_rate"]], width=width, alpha=0.65, color=ROLES["method"],
           label="upright with recovery")
    tw = [v or 0.0 for v in sw["tip_rate_without_recovery"]]
    ax.plot(np.append(th, th[:1]), np.append(tw, tw[:1]),
            ".-", color=ROLES["baseline"], label="tips without recovery")
    ax.set_ylim(0, 1)
    ax.set_title("Recovery success per downhill direction\n(0 deg = robot front down, 90 = left side down)", fontsize=9)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(-0.1, -0.15))
    return _save(fig, out, "sweep_success")

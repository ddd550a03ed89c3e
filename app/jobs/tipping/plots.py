"""Bundle figures of the tipping kind (paper 002 Figs. 5-6): margin timeline with the
threshold and the tipping edge, foot normal forces per leg, platform and body tilt, and the
recovery success rate per tilt direction."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from app.core.colors import ROLES  # noqa: E402
from app.core.plots import _save  # noqa: E402
from app.jobs.tipping.scenario import edge_name  # noqa: E402

# the colours of the replay and the dashboard (app/core/colors.py): the answer and its control
STYLE = {"no_recovery": (ROLES["baseline"], "without recovery"), "recovery": (ROLES["method"], "with recovery")}


def margin_timeline(traces: dict, summary: dict, out: Path) -> list[Path]:
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    thr = summary.get("threshold_deg", 20.0)
    codes: dict[str, int] = {}
    for name, tr in traces.items():
        color, label = STYLE.get(name, ("k", name))
        keep = tr["time_s"] >= 1.0  # the first second is the drop onto the feet
        t = tr["time_s"][keep]
        m = np.clip(tr["fasm_deg"][keep], -60, 90)
        ax.plot(t, m, color=color, label=f"FASM {label}")
        names = [edge_name(int(a), int(b)) for a, b in zip(tr["edge_leg_a"][keep], tr["edge_leg_b"][keep])]
        for n in names:
            codes.setdefault(n, len(codes))
        ax2.plot(t, [codes[n] for n in names], ".", ms=2, color=color)
    ax2.set_yticks(range(len(codes)), list(codes))
    rs = summary.get("runs", {}).get("recovery", {})
    if rs.get("detection_time_s") is not None:
        ax.axvline(rs["detection_time_s"], color="tab:orange", ls="--", lw=1, label="tipping detected")
        for a in rs.get("adjustments", []):
            if a.get("land_time_s") is not None:
                ax.axvline(a["land_time_s"], color="tab:green", ls=":", lw=1)
    ax.axhline(thr, color="gray", ls="--", lw=1, label=f"threshold {thr:g} deg")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel("S_FASM (deg)")
    ax.set_title("Stability margin and tipping edge")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    ax2.set_ylabel("critical edge")
    ax2.set_xlabel("time (s)")
    ax2.grid(alpha=0.3)
    return _save(fig, out, "margin_timeline")


def foot_forces(traces: dict, out: Path) -> list[Path]:
    fig, axes = plt.subplots(len(traces), 1, figsize=(7, 2.8 * len(traces)), sharex=True, squeeze=False)
    for ax, (name, tr) in zip(axes[:, 0], traces.items()):
        for leg in range(6):
            line, = ax.plot(tr["time_s"], tr["foot_fz_n"][:, leg] / 1e3, lw=1, label=f"leg {leg + 1}")
            if "qp_fz_n" in tr and np.any(tr["qp_fz_n"][:, leg]):
                # the QP's force for this foot while it runs: force-controlled legs follow it
                qp = np.where(tr["qp_fz_n"][:, leg] != 0, tr["qp_fz_n"][:, leg] / 1e3, np.nan)
                ax.plot(tr["time_s"], qp, lw=1, ls="--", color=line.get_color())
        ax.set_ylabel("foot F_z (kN); dashed: QP")
        ax.set_title(STYLE.get(name, ("k", name))[1])
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=6)
    axes[-1, 0].set_xlabel("time (s)")
    return _save(fig, out, "foot_forces")


def tilt(traces: dict, out: Path) -> list[Path]:
    fig, ax = plt.subplots(figsize=(7, 3))
    for name, tr in traces.items():
        color, label = STYLE.get(name, ("k", name))
        ax.plot(tr["time_s"], tr["tilt_rel_deg"], color=color, label=f"body vs ground, {label}")
    first = next(iter(traces.values()))
    if np.any(first["platform_tilt_deg"]):
        ax.plot(first["time_s"], first["platform_tilt_deg"], "k--", lw=1, label="platform tilt")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("deg")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, out, "tilt")


def sweep(sw: dict, out: Path) -> list[Path]:
    th = np.radians(sw["directions_deg"])
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="polar")
    width = 2 * np.pi / max(len(th), 1) * 0.8
    ax.bar(th, [v or 0.0 for v in sw["success_rate"]], width=width, alpha=0.6, label="upright with recovery")
    tw = [v or 0.0 for v in sw["tip_rate_without_recovery"]]
    ax.plot(np.append(th, th[:1]), np.append(tw, tw[:1]),
            "r.-", label="tips without recovery")
    ax.set_ylim(0, 1)
    ax.set_title("Recovery success per downhill direction\n(0 deg = robot front down, 90 = left side down)", fontsize=9)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(-0.1, -0.15))
    return _save(fig, out, "sweep_success")

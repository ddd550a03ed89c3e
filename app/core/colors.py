"""The one colour table: plots (matplotlib), the 3D replay (viser) and the dashboard
(plotly) colour a trace by its role, so "recovered" is the same colour everywhere.

A kind maps each of its traces to a role (``Kind.replay_style``); roles not listed here
take the palette in order. Pure data: every layer may import it.
"""

from __future__ import annotations

# role -> hex colour
ROLES: dict[str, str] = {
    "method": "#0b5cad",  # the kind's answer: recovered gait, run with recovery, the plan (blue)
    "baseline": "#c2410c",  # the control it is compared with: nominal tripod, run without recovery (orange)
    "reference": "#15803d",  # a third reference trace, e.g. a composed-vs-simulated check
    "mean": "#5b6472",  # population mean in convergence plots
    "worst": "#b91c1c",  # population worst in convergence plots
    "threshold": "#808080",  # limits and targets drawn as lines
    "support": "#1f4e79",  # feet on the ground in gait diagrams
}
# further traces (gait 1, 2, 3 ...) in order; the dashboard's palette
PALETTE: list[str] = ["#0b5cad", "#c2410c", "#15803d", "#7e22ce", "#b45309", "#0e7490", "#be185d", "#4d7c0f"]


# the dashboard's convergence plot: history.csv column -> role (other columns: the palette)
HISTORY_ROLES: dict[str, str] = {"best": "method", "baseline": "baseline", "mean": "mean", "worst": "worst"}


def page_table() -> dict:
    """The table as the dashboard's pages get it (JSON in every page's head, read by
    web/static/common.js): roles, palette, and the roles of the history's columns."""
    return {"roles": dict(ROLES), "palette": list(PALETTE), "history": dict(HISTORY_ROLES)}


def hex_color(role: str | None, index: int = 0) -> str:
    """The colour of a role, or the palette's ``index``-th for an unnamed trace."""
    if role is not None and role in ROLES:
        return ROLES[role]
    return PALETTE[index % len(PALETTE)]


def rgb(hex_value: str) -> tuple[int, int, int]:
    h = hex_value.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)

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
    "event": "#b45309",  # a moment the method acts on, drawn as a vertical line: tipping detected
    "failure": "#dc2626",  # what the method is there to avoid: a foothold in a forbidden zone, the body stopped
    "forbidden": "#111111",  # a forbidden zone (freegait's minefield)
    "safe_area": "#b8bec7",  # the safe area around a forbidden zone
    "zero": "#18202b",  # the zero line of a margin
}
# further traces (gait 1, 2, 3 ...) in order; the dashboard's palette
PALETTE: list[str] = ["#0b5cad", "#c2410c", "#15803d", "#7e22ce", "#b45309", "#0e7490", "#be185d", "#4d7c0f"]


# the convergence plot (the dashboard's and the bundle's convergence figure): history.csv
# column -> role (other columns: the palette, from its third colour, in the order drawn) ...
# (a random-search control's columns take the control's colour, its mean dashed as the search's mean)
HISTORY_ROLES: dict[str, str] = {"best": "method", "baseline": "baseline", "mean": "mean", "worst": "worst",
                                 "random_search_best": "baseline", "random_search_mean": "baseline"}
# ... and its line: (plotly dash, width in px); other columns solid, 2 px
HISTORY_LINES: dict[str, tuple[str, float]] = {"best": ("solid", 3), "generation_best": ("dot", 2),
                                               "mean": ("dash", 2), "worst": ("dot", 1.5),
                                               "random_search_mean": ("dash", 2)}


def history_styles(columns: list[str]) -> dict[str, tuple[str, str, float]]:
    """{column: (colour, dash, width)} of the convergence plot's lines, ``columns`` in the
    order drawn (the kind's series present in the history): what web/static/job.js draws
    from ``page_table`` and app/core/plots.history_lines draws in the bundle's figure."""
    return {c: (hex_color(HISTORY_ROLES.get(c), i + 2), *HISTORY_LINES.get(c, ("solid", 2.0)))
            for i, c in enumerate(columns)}


def page_table() -> dict:
    """The table as the dashboard's pages get it (JSON in every page's head, read by
    web/static/common.js): roles, palette, the roles of the history's columns and their lines."""
    return {"roles": dict(ROLES), "palette": list(PALETTE), "history": dict(HISTORY_ROLES),
            "history_lines": {k: list(v) for k, v in HISTORY_LINES.items()}}


def hex_color(role: str | None, index: int = 0) -> str:
    """The colour of a role, or the palette's ``index``-th for an unnamed trace."""
    if role is not None and role in ROLES:
        return ROLES[role]
    return PALETTE[index % len(PALETTE)]


def rgb(hex_value: str) -> tuple[int, int, int]:
    h = hex_value.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)

"""The evidence every kind's summary carries in the shared format (controls at the same
budget, robustness re-simulations), as dashboard tables with the target marked met or not.
Nothing here knows a kind: the rows come from ``summary["controls"]`` and
``summary["robustness"]`` as the kinds write them."""

from __future__ import annotations

from typing import Any

from app.web_views import kit


def _metric_cols(items: list[dict]) -> list[str]:
    cols: list[str] = []
    for it in items:
        for k in (it.get("metrics") or {}):
            if k not in cols:
                cols.append(k)
    return cols


def _nice(key: str) -> str:
    return key.replace("_", " ")


def _met_cell(v: Any) -> Any:
    if v is None:
        return kit.cell("no target", text="–")
    return kit.cell("met" if v else "not met", met=bool(v))


def _metric_cell(v: Any) -> Any:
    if isinstance(v, bool):
        return "yes" if v else "no"
    return kit.finite(v)


def controls_panel(summary: dict) -> dict | None:
    items = summary.get("controls")
    if not isinstance(items, list) or not items:
        return None
    cols = _metric_cols(items)
    rows = [[it.get("label") or _nice(str(it.get("name", ""))), it.get("evaluations")]
            + [_metric_cell((it.get("metrics") or {}).get(c)) for c in cols]
            + [_met_cell(it.get("target_met")), it.get("note") or ""] for it in items]
    cap = ("Controls at the same evaluation budget as the method unless the note says otherwise: the baseline, a random "
           "search over the same space, and the method with each part switched off. They measure how much of the result "
           "the method earns.")
    return kit.panel("controls", "Controls", cap,
                     table=kit.table(["control", "evaluations"] + [_nice(c) for c in cols] + ["target", "note"], rows))


def robustness_panel(summary: dict) -> dict | None:
    rob = summary.get("robustness")
    if not isinstance(rob, dict) or not rob.get("cases"):
        return None
    cases = rob["cases"]
    cols = _metric_cols(cases)
    rows = [[c.get("label") or _nice(str(c.get("name", "")))] + [_metric_cell((c.get("metrics") or {}).get(k)) for k in cols]
            + [_met_cell(c.get("target_met"))] for c in cases]
    met, total = rob.get("met"), rob.get("total")
    head = f"{met} of {total} cases meet the target" if met is not None and total is not None else ""
    cap = (f"The final answer re-simulated under changed conditions (finer timestep, perturbed friction and masses, ...). "
           f"Target checked: {rob.get('target') or '–'}." + (f" {head}." if head else ""))
    p = kit.panel("robustness", "Robustness", cap,
                  table=kit.table(["case"] + [_nice(c) for c in cols] + ["target"], rows))
    spread = rob.get("spread")
    if isinstance(spread, dict) and spread:
        p["table"]["foot"] = [[_nice(k), kit.finite(v.get("nominal")), kit.finite(v.get("min")), kit.finite(v.get("max"))]
                              for k, v in spread.items() if isinstance(v, dict)]
        p["table"]["foot_columns"] = ["metric", "nominal", "min", "max"]
    if met is not None and total:
        p["summary"] = {"met": met, "total": total}
    return p

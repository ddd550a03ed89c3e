"""The verdict at a glance: did the method work? Computed from a kind's headline and the
evidence records every summary carries (app/jobs/records.py), never from code that knows
a kind. ``Kind.verdict`` (app/jobs/base.py) calls ``verdict_of`` with the kind's headline
and its ``verdict_scores``; the job page, the jobs list and the study page show it.

A verdict has three parts:

- ``target``: the kind's target in words and whether the answer meets it;
- ``controls``: the method against each control at the same budget: beat, tied or lost,
  by how much in the kind's unit and direction, on the kind's scores in order (a tie on
  the first is decided by the next); with a 95 % interval where the numbers carry their
  spread (e.g. held-out draws), else "one seed: no interval";
- ``robustness``: led by the held-out random models where the block carries them
  (``records.HeldOut``, any kind's): "N of M held-out random models keep the target (95 %
  interval), F fall", the Wilson interval from app/jobs/stats.py; then k of n named cases
  (those the search saw, ``searched_on``, apart when the records say which) and k of n
  timestep checks, each its own count. Below ``KEEP_MIN`` kept or above ``FALL_MAX`` fallen
  the gait is fragile and the sentence opens with it and why ("Fragile: falls on 14 of 20
  models like yours: do not take it to the robot as it is.").

``brief`` is the list's, the API's and the client's form; ``verdict_lines`` what `gaitmend
run` prints and a bundle's README states.

``study_verdict`` pools the verdicts of a study's points over seeds: the paired difference
per control with its 95 % interval and Wilcoxon p (app/jobs/stats.py's ``paired``); beat or
lost only when the interval excludes 0 and the test rejects at 0.05, else "not shown".
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from app.jobs.records import ControlRow, HeldOut, Robustness, controls_of, robustness_of

# A two-sided 95 % Student t quantile by degrees of freedom (normal beyond the table).
_T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228,
        12: 2.179, 15: 2.131, 20: 2.086, 25: 2.060, 30: 2.042, 40: 2.021, 60: 2.000, 120: 1.980}
SCALES = (1.0, 100.0, 1000.0, 0.01, 0.001)


def t95(df: float) -> float:
    if df < 1:
        return float("inf")
    for k in sorted(_T95):
        if df <= k:
            return _T95[k]
    return 1.96


def _num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _value(x: Any) -> float | bool | None:
    if isinstance(x, bool):
        return x
    return float(x) if _num(x) else None


def fmt(x: Any, unit: str = "") -> str:
    """A number as the page shows it: 3 significant digits (whole numbers as they are)."""
    if isinstance(x, bool):
        return "yes" if x else "no"
    if not _num(x):
        return "–"
    if float(x).is_integer() and abs(x) < 1e6:
        text = str(int(x))
    elif abs(x) >= 1e5 or abs(x) < 1e-3:
        text = f"{x:.2e}"
    else:
        text = f"{x:.3g}" if abs(x) < 100 else f"{x:.0f}"
    return f"{text} {unit}".strip() if unit and unit != "%" else f"{text}{unit}"


# -- what the method is judged by ------------------------------------------------------------

def score(key: str, label: str, value: Any, unit: str = "", better: str = "higher", scale: float = 1.0,
          controls: Sequence[str] | None = None, std: float | None = None, std_key: str | None = None,
          n: int | None = None, ddof0: bool = False, only_if: str | None = None) -> dict[str, Any]:
    """One criterion the method is compared on: ``key`` in each control's metrics (times
    ``scale`` gives ``unit``), the method's ``value`` in that unit, ``better`` "higher" or
    "lower"; ``controls``: the control names it applies to (None: every control carrying
    the key); ``std``/``std_key``/``n``: the spread of the method's value and the key of a
    control's spread over the same ``n`` draws, for an interval (``ddof0``: both are
    population deviations, NumPy's default); ``only_if``: a key of the control's metrics
    that must be true for its value to count (e.g. "feasible": an infeasible answer's
    number is a penalty, not a result)."""
    return {"key": key, "label": label, "value": _value(value), "unit": unit, "better": better, "scale": scale,
            "controls": list(controls) if controls is not None else None, "std": std, "std_key": std_key, "n": n,
            "ddof0": ddof0, "only_if": only_if}


def generic_scores(summary: Mapping[str, Any], headline: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The default criterion: the first headline row with a direction whose value is the
    answer's nominal value of a metric the robustness block spreads (at a unit scale of 1,
    100, 1000, 1/100 or 1/1000): the row says label, unit and direction, the block says the
    key the controls carry. None found: no numeric comparison (controls show target met)."""
    rob = robustness_of(summary)
    nominal = {k: v.get("nominal") for k, v in (rob.spread if rob else {}).items() if isinstance(v, Mapping)}
    for row in headline:
        v = row.get("value")
        if row.get("better") not in ("higher", "lower") or not _num(v):
            continue
        for key, nom in nominal.items():
            if not _num(nom):
                continue
            for s in SCALES:
                if math.isclose(nom * s, v, rel_tol=1e-6, abs_tol=1e-12):
                    return [score(key, row["label"], v, row.get("unit") or "", row["better"], s)]
    return []


# -- the target -------------------------------------------------------------------------------

def target_of(summary: Mapping[str, Any], headline: Sequence[Mapping[str, Any]], rob: Robustness | None) -> dict:
    """The target in words and whether the answer meets it: the summary's own
    ``target``/``target_met`` pair; else the headline row judged by the target the
    robustness block checks; else every headline row that carries a target (all met)."""
    text, met = summary.get("target"), summary.get("target_met")
    if isinstance(text, str) and isinstance(met, bool):
        return {"text": text, "met": met}
    if rob is not None and rob.target:
        row = next((r for r in headline if r.get("target") == rob.target and r.get("met") is not None), None)
        if row is not None:
            return {"text": rob.target, "met": bool(row["met"])}
    judged = [r for r in headline if r.get("target") and r.get("met") is not None]
    if judged:
        return {"text": "; ".join(f"{r['label']} {r['target']}" for r in judged),
                "met": all(bool(r["met"]) for r in judged)}
    return {"text": None, "met": None}


# -- the method against one control -------------------------------------------------------------

def _interval(diff: float, crit: Mapping[str, Any], metrics: Mapping[str, Any]) -> tuple[list[float] | None, int | None]:
    """A 95 % Welch interval of the difference when both sides carry their spread over n draws."""
    n, sa, key = crit.get("n"), crit.get("std"), crit.get("std_key")
    sb = metrics.get(key) if key else None
    if not (n and n > 1 and _num(sa) and _num(sb)):
        return None, None
    s = crit.get("scale") or 1.0
    k = n / (n - 1) if crit.get("ddof0") else 1.0  # population to sample variance
    va, vb = k * (sa ** 2) / n, k * ((sb * s) ** 2) / n
    se = math.sqrt(va + vb)
    if se == 0:
        return [diff, diff], n
    df = (va + vb) ** 2 / ((va ** 2 + vb ** 2) / (n - 1)) if va + vb else n - 1
    h = t95(df) * se
    return [diff - h, diff + h], n


def _compare(crit: Mapping[str, Any], c: ControlRow) -> dict[str, Any] | None:
    """One criterion on one control: None when it does not apply (control not named, no
    value on either side)."""
    if crit.get("controls") is not None and c.name not in crit["controls"]:
        return None
    a, raw = crit.get("value"), c.metrics.get(crit["key"])
    if a is None or _value(raw) is None or (crit.get("only_if") and c.metrics.get(crit["only_if"]) is not True):
        return None
    unit, better, label = crit.get("unit") or "", crit.get("better") or "higher", crit["label"]
    base = {"on": label, "unit": unit, "better": better, "method": a, "interval": None, "seeds": None}
    if isinstance(a, bool) or isinstance(raw, bool):
        b = bool(raw)
        base |= {"control": b, "by": None}
        if bool(a) == b:
            return base | {"outcome": "tied", "text": f"tied on {label} (both {fmt(b)})"}
        win = bool(a) if better == "higher" else not bool(a)
        return base | {"outcome": "beat" if win else "lost",
                       "text": f"{'beat' if win else 'lost'} on {label} (the method: {fmt(bool(a))}; the control: {fmt(b)})"}
    b = float(raw) * (crit.get("scale") or 1.0)
    gain = (a - b) if better == "higher" else (b - a)  # > 0: the method is better
    base |= {"control": b, "by": abs(a - b)}
    interval, n = _interval(a - b, crit, c.metrics)
    vs = f"{label} {fmt(a, unit)} against {fmt(b, unit)}, {better} is better"
    if interval is not None:
        base |= {"interval": interval, "seeds": n}
        lo, hi = interval
        if lo <= 0 <= hi:
            return base | {"outcome": "tied", "text": f"tied within the 95 % interval on {n} draws ({vs})"}
    elif fmt(a, unit) == fmt(b, unit):
        return base | {"outcome": "tied", "text": f"tied: {vs}"}
    word = "beat" if gain > 0 else "lost"
    ci = "" if interval is None else \
        f"; 95 % interval of the difference {fmt(interval[0], unit)} to {fmt(interval[1], unit)} on {n} draws"
    return base | {"outcome": word, "text": f"{word} by {fmt(abs(a - b), unit)} ({vs}){ci}"}


def control_verdict(crits: Sequence[Mapping[str, Any]], c: ControlRow) -> dict[str, Any]:
    """The method against one control: the first criterion that tells them apart decides;
    the ties before it are named."""
    row = {"name": c.name, "label": c.label, "evaluations": c.evaluations, "target_met": c.target_met,
           "note": c.note, "compared": False, "outcome": None, "text": "not compared on a shared number"}
    ties = []
    for crit in crits:
        r = _compare(crit, c)
        if r is None:
            continue
        row |= r | {"compared": True}
        if r["outcome"] != "tied":
            break
        ties.append(r["on"])
    if len(ties) > 1 and row["outcome"] == "tied":
        row["text"] = "tied on " + ", ".join(ties)
    elif ties and row["outcome"] != "tied":
        row["text"] = f"{row['text']}; tied on {', '.join(ties)} first"
    if row["compared"] and row.get("interval") is None and row["outcome"] != "tied" and row["by"] is not None:
        row["text"] += "; one seed, no interval"
    return row


# -- robustness -------------------------------------------------------------------------------------

# The held-out figure decides whether a gait is fragile: below KEEP_MIN of the held-out
# random models keeping the target, or above FALL_MAX of them falling, the verdict's first
# sentence says the gait is fragile and why (docs/dashboard.md states both numbers).
KEEP_MIN = 0.80
FALL_MAX = 0.05
FRAGILE_RULE = (f"fragile when fewer than {100 * KEEP_MIN:.0f} % of the held-out random models keep the target "
                f"or more than {100 * FALL_MAX:.0f} % of them fall")

GROUP_LABELS = {"held_out": "held-out random models", "numerics": "timestep checks", "physical": "named cases",
                "searched_on": "named cases, searched on", "not_searched_on": "named cases, not searched on"}


def held_out_text(h: Mapping[str, Any]) -> str:
    """The held-out figure in words, the same on every surface: "5 of 20 held-out random
    models keep the target (95 % interval 11-47 %), 14 fall"."""
    n, met, judged, fell = h["n"], h["met"], h["judged"], h.get("fell")
    falls = "" if fell is None else f", {fell} fall"
    if not judged:
        return f"{n} held-out random models: the target judges none of them{falls}"
    lo, hi = h["interval"]
    of = f"{judged} judged" if judged < n else f"{n}"
    keep = "keeps" if met == 1 else "keep"
    return (f"{met} of {of} held-out random models {keep} the target "
            f"(95 % interval {100 * lo:.0f}–{100 * hi:.0f} %){falls}")


def held_out_verdict(h: HeldOut | None) -> dict[str, Any] | None:
    """The held-out figure: kept k of n with its 95 % Wilson interval, falls, and whether
    the gait is fragile by KEEP_MIN / FALL_MAX, with the reasons in words a user acts on."""
    if h is None:
        return None
    from app.jobs.stats import wilson

    out: dict[str, Any] = {"n": h.n, "met": h.met, "judged": h.judged, "fell": h.fell, "share": h.share,
                           "fall_share": h.fall_share, "interval": list(wilson(h.met, h.judged)) if h.judged else None,
                           "keep_min": KEEP_MIN, "fall_max": FALL_MAX, "rule": FRAGILE_RULE, "ranges": h.ranges}
    why = []
    if h.fall_share is not None and h.fall_share > FALL_MAX:
        why.append(f"falls on {h.fell} of {h.n} models like yours")
    if h.share is not None and h.share < KEEP_MIN:
        only = "only " if h.met else ""
        why.append(f"keeps the target on {only}{h.met} of {h.judged}")
    out |= {"fragile": bool(why), "why": why, "text": held_out_text(out),
            "headline": f"Fragile: {' and '.join(why)}: do not take it to the robot as it is." if why else None}
    return out


def robustness_verdict(rob: Robustness | None) -> dict[str, Any] | None:
    """k of n by group, the held-out random models first (with their interval and falls),
    then the named cases, then the timestep checks: three separate counts."""
    if rob is None or (not rob.cases and rob.held_out is None):
        return None
    held = held_out_verdict(rob.held_out)
    groups = []
    if held is not None:
        groups.append({"name": "held_out", "label": GROUP_LABELS["held_out"], "met": held["met"],
                       "total": held["n"], "judged": held["judged"], "fell": held["fell"], "text": held["text"]})
    seen = set(rob.extra.get("searched_on") or [])
    phys = [c for c in rob.cases if c.group == "physical"]
    parts = ([("searched_on", [c for c in phys if c.name in seen]),
              ("not_searched_on", [c for c in phys if c.name not in seen])] if seen else [("physical", phys)])
    parts.append(("numerics", [c for c in rob.cases if c.group == "numerics"]))
    for name, cs in parts:
        if cs:
            groups.append({"name": name, "label": GROUP_LABELS[name], "met": sum(c.target_met is True for c in cs),
                           "total": len(cs), "judged": sum(c.target_met is not None for c in cs)})
    return {"target": rob.target, "met": rob.met, "total": rob.total, "groups": groups, "held_out": held,
            "judged": sum(c.target_met is not None for c in rob.cases),
            "failed": [c.label for c in rob.cases if c.target_met is False]}


# -- the whole verdict -------------------------------------------------------------------------------

def _cases_text(rob: dict) -> str | None:
    """The named cases and the timestep checks, each k of n: "5 of 5 named cases and 2 of 2
    timestep checks meet the target"."""
    groups = [g for g in rob["groups"] if g["name"] != "held_out"]
    if not groups:
        return None
    if rob.get("judged", rob["total"]) == 0:
        return f"The {rob['total']} robustness re-runs are not judged against the target."
    words = []
    for g in groups:
        of = f"{g['judged']} judged" if g.get("judged", g["total"]) < g["total"] else f"{g['total']}"
        words.append(f"{g['met']} of {of} {g['label']}")
    return "Of the robustness re-runs, " + " and ".join(words) + " meet the target."


def _sentence(target: dict, controls: list[dict], rob: dict | None) -> str:
    parts = []
    held = (rob or {}).get("held_out")
    if held and held["fragile"]:
        parts.append(held["headline"])
    if target.get("met") is not None:
        where = " on the model it was searched on" if held else ""
        parts.append(f"Target met{where}." if target["met"] else f"Target not met{where}.")
    compared = [c for c in controls if c["compared"]]
    if compared:
        n = {w: sum(c["outcome"] == w for c in compared) for w in ("beat", "tied", "lost")}
        parts.append(f"Against {len(compared)} control{'s' if len(compared) > 1 else ''} at the same budget: "
                     + ", ".join(f"{k} {v}" for k, v in n.items() if v) + ".")
    if held:
        parts.append(held["text"][0].upper() + held["text"][1:] + ".")
    cases = _cases_text(rob) if rob is not None else None
    if cases:
        parts.append(cases)
    return " ".join(parts) if parts else "No target, controls or robustness runs recorded."


def verdict_of(summary: Mapping[str, Any], headline: Sequence[Mapping[str, Any]],
               scores: Sequence[Mapping[str, Any]] | None = None, target: Mapping[str, Any] | None = None,
               primary: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The verdict of one summary (JSON). ``scores``: the criteria in order (default
    ``generic_scores``); ``target``: {"text", "met", "note"?} instead of ``target_of``;
    ``primary``: the headline row the list shows (default: the first with a direction)."""
    rob = robustness_of(summary)
    crits = list(scores) if scores is not None else generic_scores(summary, headline)
    tgt = dict(target) if target is not None else target_of(summary, headline, rob)
    controls = [control_verdict(crits, c) for c in controls_of(summary)]
    robv = robustness_verdict(rob)
    return {"target": tgt, "primary": dict(primary) if primary is not None else list_row(headline),
            "controls": controls, "robustness": robv, "criteria": [c["label"] for c in crits],
            "sentence": _sentence(tgt, controls, robv)}


def verdict_lines(v: Mapping[str, Any]) -> list[str]:
    """The verdict as `gaitmend run` prints it and a bundle's README states it: the sentence
    (a fragile gait's first words say so) and, where there is a held-out set, the rule that
    calls a gait fragile and the ranges its models are drawn from."""
    out = [f"Verdict: {v.get('sentence') or 'none recorded'}"]
    held = (v.get("robustness") or {}).get("held_out")
    if held:
        drawn = f" The held-out models are drawn from: {held['ranges']}." if held.get("ranges") else ""
        out.append(f"A gait is called {held['rule']}.{drawn}")
    return out


def list_row(headline: Sequence[Mapping[str, Any]]) -> dict[str, Any] | None:
    """The headline row a list shows: the first with a direction and a value, else the first."""
    for r in headline:
        if r.get("better") in ("higher", "lower") and r.get("value") is not None:
            return dict(r)
    return dict(headline[0]) if headline else None


BRIEF_HELD_OUT = ("n", "met", "judged", "fell", "share", "interval", "fragile", "text", "headline")


def brief(v: Mapping[str, Any]) -> dict[str, Any]:
    """The verdict as a list row shows it: target met, beat / tied / lost counts, the
    held-out figure (kept, falls, fragile, in words) and the re-runs k of n."""
    compared = [c for c in v.get("controls") or [] if c.get("compared")]
    rob = v.get("robustness")
    held = (rob or {}).get("held_out")
    return {"target_met": (v.get("target") or {}).get("met"),
            "controls": {w: sum(c["outcome"] == w for c in compared) for w in ("beat", "tied", "lost")},
            "held_out": {k: held[k] for k in BRIEF_HELD_OUT} if held else None,
            "robustness": [rob["met"], rob["total"]] if rob else None, "sentence": v.get("sentence")}


# -- over a study's seeds -------------------------------------------------------------------------------

def pooled(diffs: Sequence[float]) -> dict[str, Any]:
    """Mean paired difference (method better > 0) over n seeds, through app/jobs/stats.py's
    ``paired``: its 95 % interval (Student t below 10 seeds, BCa bootstrap from 10) and
    Wilcoxon's signed-rank p; "beat" / "lost" only when the interval excludes 0 and p < 0.05
    (stats.decision), else "not shown", with the reason in ``why``."""
    from app.jobs import stats

    n = len(diffs)
    r = stats.paired([float(d) for d in diffs], [0.0] * n)
    if n < 2:
        why = "one seed: no interval" if n else "no seeds"
        return {"n": n, "mean": r["mean_diff"], "interval": None, "interval_method": r["ci_method"], "p": r["p"],
                "test": r["test"], "outcome": "not shown", "why": why}
    side, why = stats.decision(r["ci"], r["p"], r["min_p"], r["confidence"], n=n)
    return {"n": n, "mean": r["mean_diff"], "interval": r["ci"], "interval_method": r["ci_method"], "p": r["p"],
            "test": r["test"], "outcome": {1: "beat", -1: "lost", 0: "not shown"}[side], "why": why}


def pooled_held_out(robs: Sequence[Mapping[str, Any]]) -> dict[str, Any] | None:
    """The held-out figure over a group's points: their held-out models pooled (kept, judged,
    fell summed), judged by the same thresholds as one job's."""
    hs = [r["held_out"] for r in robs if r.get("held_out")]
    if not hs:
        return None
    fell = None if any(h["fell"] is None for h in hs) else sum(h["fell"] for h in hs)
    return held_out_verdict(HeldOut(n=sum(h["n"] for h in hs), met=sum(h["met"] for h in hs),
                                    judged=sum(h["judged"] for h in hs), fell=fell)) | {"points": len(hs)}


def study_verdict(verdicts: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Pools point verdicts (one per seed of the same setting): target met k of n, per
    control the paired difference on the first criterion both sides carry, robustness
    summed."""
    per: dict[str, dict[str, Any]] = {}
    for v in verdicts:
        for c in v.get("controls") or []:
            if not c.get("compared") or c.get("by") is None:
                continue
            d = per.setdefault(c["name"], {"label": c["label"], "on": c["on"], "unit": c["unit"],
                                           "better": c["better"], "diffs": []})
            if c["on"] != d["on"]:
                continue
            sign = 1.0 if c["better"] == "higher" else -1.0
            d["diffs"].append(sign * (c["method"] - c["control"]))
    met = [v["target"]["met"] for v in verdicts if (v.get("target") or {}).get("met") is not None]
    robs = [v["robustness"] for v in verdicts if v.get("robustness")]
    return {"points": len(verdicts), "target_met": [sum(met), len(met)], "held_out": pooled_held_out(robs),
            "controls": [{"name": k, **{x: d[x] for x in ("label", "on", "unit", "better")}, **pooled(d["diffs"])}
                         for k, d in per.items()],
            "robustness": [sum(r["met"] for r in robs), sum(r["total"] for r in robs)] if robs else None}

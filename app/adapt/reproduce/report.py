"""docs/adapt.md's "Evaluation" section, rendered from docs/adapt_evaluation.json (written by
`gaitmend reproduce adapt --write-docs`, app/adapt/reproduce/evaluation.py): no number on
the page is typed by hand.

Per arm: the share of realities recovered within 20 trials with its Wilson interval
(app/jobs/stats.py ``wilson``); trials to recover, median and quartiles over every reality,
a reality not recovered counted as more than 20 (so a median over 20 reads "> 20"); the
gap to the oracle (the best forward speed of a gait of the maps that does not fall on that
reality, less the speed of the gait the arm ends on, 0 when it fell). Paired by reality:
trials to recover (not recovered = 21) and the gap with app/jobs/stats.py ``paired`` (mean
difference, its interval, Wilcoxon signed-rank), recovered or not with McNemar's exact test
(scipy.stats.binomtest on the discordant pairs)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from app.jobs.reporting import Section, md_table
from app.jobs.stats import paired, paired_text, wilson

JSON = "docs/adapt_evaluation.json"
COMMAND = "gaitmend reproduce adapt --write-docs"
NAME = "adapt-evaluation"
ANT_JSON = "docs/adapt_evaluation_ant.json"  # the uploaded robot's (app/adapt/reproduce/params.py)
ANT_COMMAND = "gaitmend reproduce adapt-ant --write-docs"
ANT_NAME = "adapt-evaluation-ant"
NOT_RECOVERED = 21  # trials to recover of a reality not recovered within 20, in the paired test
ORDER = ("gaitmend", "gaitmend_scenarios", "expected", "gaitmend_worlds", "gaitmend_worlds_2", "expected_worlds", "ite",
         "random", "de_believed",
         "ite_target", "no_priors", "no_straight", "no_falls", "no_repeat_off",
         "no_target", "no_target_no_guard")
PAIRS = (("gaitmend", "ite"), ("gaitmend_scenarios", "ite"), ("gaitmend", "random"), ("ite", "random"),
         ("gaitmend", "ite_target"), ("gaitmend", "no_priors"), ("gaitmend_scenarios", "gaitmend"),
         ("gaitmend", "de_believed"))


def _trials(rows: list[dict], arm: str) -> np.ndarray:
    return np.array([r["arms"][arm]["recovered_at"] or math.inf for r in rows], dtype=float)


def _gap(rows: list[dict], arm: str) -> np.ndarray:
    return np.array([r["oracle"]["best_speed_m_s"] - r["arms"][arm]["final_speed_m_s"] for r in rows], dtype=float)


def _q(v: float) -> str:
    return "> 20" if not math.isfinite(v) or v > 20 else f"{v:g}"


def _quartiles(t: np.ndarray) -> tuple[float, float, float]:
    """Median and quartiles with inf for a reality not recovered (numpy's 'lower' method:
    each figure is one of the realities' values, so inf stays inf)."""
    return tuple(float(np.percentile(t, q, method="lower")) for q in (50, 25, 75))


def summary(data: dict, rows: list[dict] | None = None, pairs=PAIRS) -> dict[str, Any]:
    """Per arm and per pair of arms, over ``rows`` (default every reality of the file)."""
    rows = data["realities"] if rows is None else rows
    n = len(rows)
    arms = [a for a in ORDER if rows and all(a in r["arms"] for r in rows)]
    out: dict[str, Any] = {"n": n, "arms": {}, "pairs": {}}
    for a in arms:
        t = _trials(rows, a)
        k = int(np.sum(np.isfinite(t)))
        lo, hi = wilson(k, n)
        med, q1, q3 = _quartiles(t)
        out["arms"][a] = {"recovered": k, "share": k / n if n else None, "wilson": [lo, hi], "median": med,
                          "q1": q1, "q3": q3, "gap_median": float(np.median(_gap(rows, a))),
                          "trials_run_median": float(np.median([r["arms"][a]["trials"] for r in rows])),
                          "stopped_unrecovered": int(sum(r["arms"][a]["recovered_at"] is None
                                                         and r["arms"][a]["trials"] < 20 for r in rows))}
    for a, b in pairs:
        if a not in out["arms"] or b not in out["arms"] or n < 2:
            continue
        ta, tb = (np.minimum(_trials(rows, x), NOT_RECOVERED) for x in (a, b))
        ra, rb = np.isfinite(_trials(rows, a)), np.isfinite(_trials(rows, b))
        only_a, only_b = int(np.sum(ra & ~rb)), int(np.sum(rb & ~ra))
        from scipy.stats import binomtest

        mc = binomtest(only_a, only_a + only_b, 0.5).pvalue if only_a + only_b else 1.0
        out["pairs"][f"{a}-{b}"] = {
            "trials": paired(ta, tb, higher_is_better=False, names=(a, b)),
            "gap": paired(_gap(rows, a), _gap(rows, b), higher_is_better=False, names=(a, b)),
            "recovered": {"only_first": only_a, "only_second": only_b, "mcnemar_p": float(mc)}}
    oracle = [r["oracle"]["best_speed_m_s"] >= r["target_m_s"] for r in rows]
    ite_oracle = [r["oracle"]["ite_map_best_speed_m_s"] >= r["target_m_s"] for r in rows]
    rho = [r["oracle"].get("ite_map_rank_correlation") for r in rows]
    rho = [x for x in rho if x is not None]
    out["rank_correlation"] = [float(np.percentile(rho, q)) for q in (50, 25, 75)] if rho else None
    ite = data["setup"]["maps"][0]["name"]
    share = [r["oracle"]["maps"][ite]["recovering_elites"] / r["oracle"]["maps"][ite]["elites"] for r in rows]
    out["ite_map_recovering_share"] = [float(np.percentile(share, q)) for q in (50, 25, 75)] if share else None
    out["oracle_recoverable"] = int(sum(oracle))
    out["ite_map_recoverable"] = int(sum(ite_oracle))
    return out


def _budget_text(setup: dict) -> str:
    b = setup["map_budget"]
    s = b["search"]
    return (f"{s['iterations']} MAP-Elites iterations x {s['batch_size']} gaits ({s['iterations'] * s['batch_size']} "
            f"evaluations) per map into {b['archive']['cells']} cells, trials of {b['sim']['duration_s']:g} s after "
            f"{b['sim']['settle_s']:g} s of settling at a {b['sim']['timestep_s'] * 1000:g} ms timestep")


HELD_OUT_ARMS = ("gaitmend_scenarios", "expected", "gaitmend_worlds", "gaitmend_worlds_2", "expected_worlds",
                 "gaitmend", "ite", "random", "de_believed")
HELD_OUT_PAIRS = (("gaitmend_scenarios", "ite"), ("gaitmend_worlds", "ite"), ("gaitmend_worlds_2", "ite"),
                  ("gaitmend_worlds", "random"),
                  ("gaitmend_worlds", "gaitmend"), ("gaitmend_worlds", "de_believed"))


def _tables(st: dict, s: dict, n: int, arms=None) -> list[str]:
    """The arms' table and the paired comparisons of a summary."""
    table = []
    for a, v in s["arms"].items():
        if arms is not None and a not in arms:
            continue
        words = st["de_believed"]["words"] if a == "de_believed" else st["arms"].get(a, {}).get("words", "")
        table.append([f"`{a}`", words,
                      f"{v['recovered']}/{n} = {v['share']:.2f} [{v['wilson'][0]:.2f}, {v['wilson'][1]:.2f}]",
                      f"{_q(v['median'])} [{_q(v['q1'])}, {_q(v['q3'])}]", f"{v['trials_run_median']:g}",
                      str(v["stopped_unrecovered"]), f"{v['gap_median'] * 100:.1f}"])
    lines = [md_table(["arm", "what", "recovered within 20 (Wilson 95 %)", "trials to recover: median [quartiles]",
                       "trials run (median)", "stopped before recovering", "gap to the oracle (cm/s, median)"], table)]
    lines.append("Paired by reality (a positive difference favours the first arm; trials to recover counts a "
                 f"reality not recovered as {NOT_RECOVERED}):\n")
    for key, v in s["pairs"].items():
        a, b = key.split("-")
        r = v["recovered"]
        lines.append(f"- `{a}` against `{b}`: trials to recover {paired_text(v['trials'], 'trials', 1)}; gap to the "
                     f"oracle {paired_text(v['gap'], 'm/s', 3)}; recovered by one arm only: `{a}` {r['only_first']}, "
                     f"`{b}` {r['only_second']} (McNemar exact p = {r['mcnemar_p']:.3g})")
    lines.append("")
    return lines


def _robot_text(st: dict) -> str:
    if st.get("uploaded"):
        return (f"the Gymnasium ant, uploaded as a user's robot is ({st['robot']}, robot id "
                f"{st['robot_id'][:8]}...; its damages by its leg map's names)")
    return f"the hexapod ({st['robot']})"


def _target_text(st: dict, target: float) -> str:
    if st.get("uploaded"):
        return (f"{target * 100:.1f} cm/s or faster without falling (the hexapod's 5 cm/s scaled by the ant's leg "
                f"length against the hexapod's, app/adapt/recovered.py)")
    return f"{target * 100:.0f} cm/s or faster without falling"


def render(data: dict | None, json_path: str = JSON, command: str = COMMAND) -> str:
    if not data or not data.get("realities"):
        return f"No evaluation has run yet: `{command}` writes {json_path} and this section.\n"
    st = data["setup"]
    s = summary(data)
    rows = data["realities"]
    n = s["n"]
    types = {t: sum(r["type"] == t for r in rows) for t in st["types"]}
    lines = [
        f"{n} simulated realities of {_robot_text(st)} ran"
        + (" (the quick, test-sized setup)" if st["quick"] else "")
        + " (the issue asks for at least 30): " + ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in types.items())
        + f", each with a held-out perturbation (friction, masses, payload, half of them a rough floor). "
        f"Maps: {', '.join(m['name'] + ' (' + str(m['elites']) + ' elites)' for m in st['maps'])}, each "
        f"{_budget_text(st)}; a much smaller budget than ITE's (its maps held about 13,000 gaits). No reality's "
        f"damage is a map's. Recovered: a trial at {_target_text(st, rows[0]['target_m_s'])}. "
        f"The maps hold a recovering gait on {s['oracle_recoverable']}/{n} realities (ITE's map alone on "
        f"{s['ite_map_recoverable']}/{n}): the ceiling of every arm.",
        "",
    ]
    if s["rank_correlation"]:
        r, sh = s["rank_correlation"], s["ite_map_recovering_share"]
        lines.append(f"How much ITE's map knows of a reality: the Spearman rank correlation between its elites' "
                     f"predicted and measured speed (a fall as 0) has median {r[0]:.2f} (quartiles {r[1]:.2f}, "
                     f"{r[2]:.2f}) over the realities; the share of its elites that recover has median {sh[0]:.2f} "
                     f"(quartiles {sh[1]:.2f}, {sh[2]:.2f}).\n")
    lines += _tables(st, s, n)
    seen = st.get("design_seen")
    if seen is not None and n > seen:
        held = rows[seen:]
        h = summary(data, held, HELD_OUT_PAIRS)
        lines.append(f"The arms `gaitmend_scenarios`, `expected`, `gaitmend_worlds`, `gaitmend_worlds_2` and "
                     f"`expected_worlds` were added "
                     f"after the first {seen} realities' results were seen. On the {len(held)} realities after those "
                     "(held out from that design):\n")
        lines += _tables(st, h, len(held), HELD_OUT_ARMS)
    seen = st.get("design_seen") or 0
    for ours, subset in (("gaitmend", None), ("gaitmend_scenarios", seen), ("gaitmend_worlds", seen)):
        part = rows[subset:] if subset else rows
        if ours not in s["arms"] or "ite" not in s["arms"] or not part:
            continue
        sub = summary(data, part, ((ours, "ite"),))
        g, vs = sub["arms"][ours], sub["pairs"].get(f"{ours}-ite", {})
        goals = [("a median of at most 5 trials", math.isfinite(g["median"]) and g["median"] <= 5),
                 ("at least 90 % recovered within 20", g["share"] >= 0.9),
                 ("fewer trials than ITE on the same realities", vs.get("trials", {}).get("shown") == "method")]
        where = f"the {len(part)} realities held out from its design" if subset else f"all {len(part)} realities"
        lines.append(f"The issue's goals for `{ours}` on {where}: " + "; ".join(
            f"{w}: **{'met' if ok else 'not met'}**" for w, ok in goals) + ".\n")
    lines.append("")
    lines.append(_de_text(st, rows))
    return "\n".join(lines) + "\n"


def _de_text(st: dict, rows: list[dict]) -> str:
    """What the page says of the DE arm: how it was run, how far it has got, its refusals."""
    de = st["de_believed"]
    if not de.get("run"):
        return f"The recovery kind's DE searched on the believed damage: {de['reason']}."
    done = [r["arms"]["de_believed"] for r in rows if "de_believed" in r["arms"]]
    text = (f"`de_believed`: {de['words']}; the recovery spec's fixed fields {json.dumps(de['spec'])}, the search's "
            f"seed the reality's. It ran on {len(done)} of the {len(rows)} realities")
    if len(done) < len(rows):
        text += " (the tables leave it out until it has run on every one)"
    refused = [d for d in done if d["stop"].startswith("refused")]
    if refused:
        text += (f"; the recovery kind refused {len(refused)} believed damages (no gait for the lab: counted as not "
                 f"recovered), e.g. {refused[0]['stop'].removeprefix('refused: ')}")
    ran = [d for d in done if not d["stop"].startswith("refused")]
    if ran:
        met = sum(1 for d in ran if d.get("believed_target_met"))
        text += (f"; its answer met the recovery target on the believed damage's nominal model on {met} of "
                 f"{len(ran)}")
    return text + "."


def sections() -> list[Section]:
    return [Section(NAME, (JSON,), lambda d: render(d[0])),
            Section(ANT_NAME, (ANT_JSON,), lambda d: render(d[0], ANT_JSON, ANT_COMMAND))]

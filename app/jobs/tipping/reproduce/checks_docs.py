"""docs/tipping.md's findings 2 (friction) and 3 (timing), its "Convergence rule" and its
"Robustness" paragraph, rendered from the ledgers app/jobs/tipping/reproduce/checks.py writes
(docs/tipping_friction.json, _timing, _convergence, _robustness): the tables and every
number the paragraphs state, each beside issue 12's hand-typed record of it."""

from __future__ import annotations

import math
from collections.abc import Sequence

from app.jobs import stats
from app.jobs.ledger import current_runs, machine_time, results_by_name
from app.jobs.reporting import Section, md_table, missing, num, progress_note, yes
from app.jobs.tipping.evidence import CONVERGENCE_TOL, ROBUSTNESS_CASES, convergence_row, recovery_target
from app.jobs.tipping.reproduce.reruns_docs import _span
from app.jobs.tipping.spec import TippingSpec

FRICTION_JSON = "docs/tipping_friction.json"
FRICTION_COMMAND = "gaitmend reproduce tipping-friction --write-docs"
TIMING_JSON = "docs/tipping_timing.json"
TIMING_COMMAND = "gaitmend reproduce tipping-timing --write-docs"
CONVERGENCE_JSON = "docs/tipping_convergence.json"
CONVERGENCE_COMMAND = "gaitmend reproduce tipping-convergence --write-docs"
ROBUST_JSON = "docs/tipping_robustness.json"
ROBUST_COMMAND = "gaitmend reproduce tipping-robustness --write-docs"
CASES_JSON = "docs/tipping_cases.json"  # the six cases' ledger (experiments.py): its controls
ORDER = ("climbing", "descending", "lateral")
MODE_WORDS = {"qp_force": "force-controlled stance (the QP's forces)", "position_stance": "position servos (QP as "
              "feed-forward)", "no_qp": "no QP"}
TARGET = recovery_target(0.0)
PAPER_BAR_DEG = 20.0  # the paper's own bar for a recovery: the margin back above the detection threshold
DEFAULT_FRICTION = 1.5

# Issue 12's hand-typed records (docs/tipping.md at 049d560, measured 2026-12-02; no data was
# committed), as its text states them: the blocks set each beside the re-run's own number.
RECORD = {
    "friction": {"qp_err_ud": "3.6-4.3", "qp_err_lat": "6.9-7.6", "pos_err": "15.7-46.8",
                 "demand": {"qp_force": "0.87 / 0.92", "position_stance": "1.21 / 1.20", "no_qp": "0.99 / 1.22"},
                 "margins": "15.8-16.1 / 19.1-19.2 / 13.3-13.6", "tips_low": "0", "slip_pos_cm": "1-3",
                 "slip_force_cm": "1.7-4.2"},
    "timing": {"ts_10": "1.71 / 1.82 / 1.52", "fall_10": "2.14 / 2.08, 2.27 / 2.16",
               "fall_3": "7.19 / 7.12, 7.30 / 7.24", "ts_20": "0.25-0.28", "fall_20": "0.82-1.00", "swing_20": "0.40",
               "fixed_up": "9 of 9", "fixed_vs_eq_10": "20.3 / 16.1, 22.6 / 19.2", "eq_wins_20": "21.6 / 9.9"},
    # the record's "tipped at 2 ms and stayed up at 1 ms (Eq. 15 gave 5.63 s against 2.45 s)", in the block's words
    "convergence": {"2": {"dirs": "directions not named", "margin": "1.7", "ts": "0.15",
                          "out": "270 (tipped at 2 ms: yes, at 1 ms: no; Eq. 15 5.63 / 2.45 s)"},
                    "1": {"dirs": "180, 0, 90, 270", "margin": "0.25", "detection": "0.00", "ts": "0.01", "out": "none"}},
    "robustness": {"climbing": ("7/7", "15.8-16.1", "4.86-4.96"), "descending": ("7/7", "11.4-19.4", "4.44-4.52"),
                   "lateral": ("7/7", "12.3-13.3", "6.16-6.26"), "demand": "0.87-0.94",
                   "payload": "no finite Eq. 15 time descending, the swing at its 4 s maximum"},
}


def _against(items: Sequence[tuple[str, str, str]]) -> str:
    """One bullet: each (what, the record's value, this re-run's) with same or differs."""
    parts = [f"{what}: record {rec}, here {here} ({'same' if rec == here else 'differs'})" for what, rec, here in items]
    return ("- Against issue 12's hand-typed record (2026-12-02, no data committed): " + "; ".join(parts) + ".\n")


def _cost(data: dict, what: str) -> str:
    mt = machine_time(data)
    loads = [r["result"]["load_after"] for r in current_runs(data) if "load_after" in r["result"]]
    cores = next((r["result"].get("cores") for r in current_runs(data)), "?")
    return (f"\nMachine time: {mt['runs']} {what}, {mt['wall_s']:.0f} s wall, {mt['cpu_s']:.0f} s CPU (load average "
            f"{_span(loads)} at their ends on {cores} cores, beside other work).\n")


def _grid(data: dict) -> dict[tuple[str, ...], dict]:
    """{name split at ":": result} of the current runs."""
    return {tuple(n.split(":")): r for n, r in results_by_name(data).items()}


def _f(v: float | None, fmt: str = "{:.2f}") -> str:
    return num(v, fmt)


# -- finding 2: friction ------------------------------------------------------------------------

def _friction_table(g: dict) -> str:
    rows = []
    for (mu, case, mode), r in g.items():
        loads = ", ".join(f"{leg}: {v:.0f}" for leg, v in (r.get("stance_load_pct") or {}).items())
        rows.append([mu, case, MODE_WORDS[mode], yes(not r["tipped"]), _f(100 * r["max_slip_m"], "{:.1f}"),
                     _f(r["friction_demand"]), _f(r["margin_after_landing_deg"], "{:.1f}"),
                     _f(r["qp_force_error_pct"], "{:.1f}"), loads or "-"])
    return md_table(["friction", "case", "stance control", "upright", "largest foot slip (cm)", "friction demand",
                     "margin after landing (deg)", "measured - QP force, worst stance foot (% of weight)",
                     "stance feet's vertical load, last second (leg: % of weight)"], rows)


def _by_mode(g: dict, mus: Sequence[str], cases: Sequence[str], mode: str, key: str, scale: float = 1.0) -> list:
    return [None if g[(m, c, mode)][key] is None else scale * g[(m, c, mode)][key]
            for m in mus for c in cases if (m, c, mode) in g]


def _friction_text(g: dict, tilt: float) -> tuple[str, list[tuple[str, str, str]]]:
    tan = math.tan(math.radians(tilt))
    mus = list(dict.fromkeys(k[0] for k in g))
    base = [m for m in mus if float(m) == DEFAULT_FRICTION]
    low = [m for m in mus if tan <= float(m) < DEFAULT_FRICTION]
    slide = [m for m in mus if float(m) < tan]
    lines, rec = [], []
    err_ud = _span(_by_mode(g, low, ORDER[:2], "qp_force", "qp_force_error_pct"))
    err_lat = _span(_by_mode(g, low, ORDER[2:], "qp_force", "qp_force_error_pct"))
    err_pos = _span(_by_mode(g, low, ORDER, "position_stance", "qp_force_error_pct"))
    lines.append(f"- The stance feet's measured force against the QP's, worst stance foot, at friction "
                 f"{', '.join(low) or '-'} (from 1 s after the caught leg lands to the end): force-controlled "
                 f"{err_ud} % of the weight climbing and descending, {err_lat} % lateral; position servos {err_pos} %.")
    rec += [("worst foot, force-controlled, climbing and descending (%)", RECORD["friction"]["qp_err_ud"], err_ud),
            ("lateral (%)", RECORD["friction"]["qp_err_lat"], err_lat),
            ("position servos (%)", RECORD["friction"]["pos_err"], err_pos)]
    demand = {m: " / ".join(_f(v) for v in _by_mode(g, base, ORDER[:2], m, "friction_demand")) for m in MODE_WORDS}
    lateral = {m: " / ".join(_f(v) for v in _by_mode(g, base, ORDER[2:], m, "friction_demand")) for m in MODE_WORDS}
    lines.append(f"- Friction demand at friction {', '.join(base) or '-'} (climbing / descending, then lateral; "
                 f"tan({tilt:g} deg) = {tan:.2f}): " + "; ".join(f"{MODE_WORDS[m]} {d}, lateral {lateral[m]}"
                                                              for m, d in demand.items()) + ".")
    rec += [(f"friction demand, {MODE_WORDS[m]}", RECORD["friction"]["demand"][m], d) for m, d in demand.items()]
    pos = [(c, g[(m, c, "position_stance")].get("stance_load_pct") or {}) for m in base for c in ORDER
           if (m, c, "position_stance") in g]
    unl = [f"{c} leg {min(ld, key=ld.get)} at {min(ld.values()):.0f} %" for c, ld in pos if ld]
    lines.append(f"- Least-loaded stance foot with position servos at friction {', '.join(base) or '-'}: "
                 f"{', '.join(unl) or '-'} of the weight (last second).")
    spans = [_span([v for m in MODE_WORDS for v in _by_mode(g, base, [c], m, "margin_after_landing_deg")]) for c in ORDER]
    spread = max((max(v) - min(v) for c in ORDER for v in [[x for m in MODE_WORDS for x in _by_mode(
        g, base, [c], m, "margin_after_landing_deg") if x is not None]] if v), default=None)
    lines.append(f"- Margin after landing over the three stance controls at friction {', '.join(base) or '-'}: "
                 f"climbing {spans[0]}, descending {spans[1]}, lateral {spans[2]} deg (the largest spread in a case "
                 f"{_f(spread, '{:.1f}')} deg).")
    rec.append(("margins over the controls (climbing / descending / lateral, deg)", RECORD["friction"]["margins"],
                " / ".join(spans)))
    rec += _low_friction(g, low, slide, tan, lines)
    return "\n".join(lines) + "\n", rec


def _low_friction(g: dict, low: list[str], slide: list[str], tan: float, lines: list[str]) -> list:
    """The low-friction outcome lines (appended to ``lines``) and their record items."""
    def up(ms: list[str]) -> tuple[int, int]:
        rs = [r for k, r in g.items() if k[0] in ms]
        return sum(not r["tipped"] for r in rs), len(rs)

    slips = {m: _span(_by_mode(g, low, ORDER, m, "max_slip_m", 100.0)) for m in MODE_WORDS}
    k, n = up(low)
    far = [(g[(m, c, "qp_force")]["max_slip_m"], g[(m, c, "position_stance")]["max_slip_m"]) for m in low for c in ORDER
           if (m, c, "qp_force") in g and (m, c, "position_stance") in g]
    lines.append(f"- At friction {', '.join(low) or '-'}: upright in {k} of {n} runs; largest foot slip "
                 + "; ".join(f"{MODE_WORDS[m]} {s} cm" for m, s in slips.items())
                 + f" (force-controlled at least as far as position servos in {sum(a >= b for a, b in far)} of {len(far)}).")
    if slide:
        ks, ns = up(slide)
        lines.append(f"- Below tan = {tan:.2f}, at friction {', '.join(slide)}: upright in {ks} of {ns} runs; largest "
                     f"foot slip {_span([100 * r['max_slip_m'] for kk, r in g.items() if kk[0] in slide], '{:.0f}')} cm.")
    decides = [k for k in {(m, c) for m, c, _ in g}
               if len({g[(k[0], k[1], m)]["tipped"] for m in MODE_WORDS if (k[0], k[1], m) in g}) > 1]
    pairs = [(g[(m, c, "qp_force")], g[(m, c, "no_qp")]) for m, c, mode in g if mode == "qp_force" and (m, c, "no_qp") in g]
    pairs = [(a["margin_after_landing_deg"], b["margin_after_landing_deg"]) for a, b in pairs
             if a["margin_after_landing_deg"] is not None and b["margin_after_landing_deg"] is not None]
    res = stats.paired([a for a, _ in pairs], [b for _, b in pairs], names=("with the QP", "without the QP"))
    lines.append(f"- The stance control decides upright or tipped in {len(decides)} of {len({(m, c) for m, c, _ in g})} "
                 f"(friction, case) pairs{' (' + ', '.join(f'{m} {c}' for m, c in sorted(decides)) + ')' if decides else ''}. "
                 f"Margin after landing, force-controlled QP against no QP, paired over the (friction, case) pairs "
                 f"where both caught a leg: {stats.paired_text(res, 'deg')}.")
    return [("runs tipped at friction " + ", ".join(low), RECORD["friction"]["tips_low"], str(n - k)),
            ("foot slip, position servos (cm, whole cm)", RECORD["friction"]["slip_pos_cm"],
             _span(_by_mode(g, low, ORDER, "position_stance", "max_slip_m", 100.0), "{:.0f}")),
            ("force-controlled (cm)", RECORD["friction"]["slip_force_cm"], slips["qp_force"])]


def render_friction(datas: list) -> str:
    data = datas[0]
    g = _grid(data) if data else {}
    if not g:
        return missing(FRICTION_JSON, FRICTION_COMMAND)
    tilt = data["params"].get("max_tilt_deg", 40.0)
    text, rec = _friction_text(g, tilt)
    return (_friction_table(g) + "\n" + text + _against(rec) + _cost(data, "simulations")
            + "\n" + stats.PAIRED_NOTE + "\n" + progress_note(data, len(current_runs(data))))


# -- finding 3: timing --------------------------------------------------------------------------

def _fall(g: dict, rate: str, case: str) -> float | None:
    """When the margin reaches 0 without recovery, from the Eq. 15 run's judgment (s)."""
    eq, base = g.get((rate, case, "eq15")), g.get((rate, case, "no_recovery"))
    if not eq or not base or eq["detection_time_s"] is None or base.get("margin_zero_s") is None:
        return None
    return base["margin_zero_s"] - eq["detection_time_s"]


def _ts_k(r: dict) -> float | None:
    return None if r["time_to_tip_s"] is None else r["time_to_tip_s"] / r["kappa"]


def _timing_table(g: dict, rates: list[str]) -> str:
    rows = []
    for rate in rates:
        for c in ORDER:
            eq, fx = g.get((rate, c, "eq15")), g.get((rate, c, "fixed"))
            if not eq or not fx:
                continue
            rows.append([rate, c, _f(eq["time_to_tip_s"]), _f(_ts_k(eq)), _f(_fall(g, rate, c)),
                         f"{_f(eq['detection_time_s'])} ({eq['platform_at_detection'] or '-'})",
                         f"{_f(eq['swing_s'])} / {_f(fx['swing_s'])}", f"{yes(not eq['tipped'])} / {yes(not fx['tipped'])}",
                         f"{_f(eq['margin_after_landing_deg'], '{:.1f}')} / {_f(fx['margin_after_landing_deg'], '{:.1f}')}"])
    return md_table(["rate (deg/s)", "case", "Eq. 15 t_s (s)", "t_s / kappa (s)", "margin reaches 0 after the judgment, "
                     "no recovery (s)", "judged at (s; the platform)", "swing Eq. 15 / fixed (s)",
                     "upright Eq. 15 / fixed", "margin after landing Eq. 15 / fixed (deg)"], rows)


def _pair_words(g: dict, rate: str, cases: Sequence[str]) -> str:
    return ", ".join(f"{_f(_ts_k(g[(rate, c, 'eq15')]))} / {_f(_fall(g, rate, c))}" for c in cases
                     if (rate, c, "eq15") in g)


def _ramp_ends(data: dict) -> dict[str, float]:
    """{rate: when the platform's start-up ramp ends (s)} from the runs' job specs."""
    out = {}
    for r in current_runs(data):
        sc = TippingSpec.model_validate(r["spec"]["job"]).scenario
        out[f"{sc.rate_deg_s:g}"] = sc.settle_s + min(1.0, sc.max_tilt_deg / sc.rate_deg_s)
    return out


def _timing_text(g: dict, rates: list[str], ramp_end: dict[str, float]) -> tuple[str, list]:
    lines, rec = [], []
    for rate in rates:
        eq = [g[(rate, c, "eq15")] for c in ORDER if (rate, c, "eq15") in g]
        ratio = [_ts_k(g[(rate, c, "eq15")]) / _fall(g, rate, c) for c in ORDER
                 if (rate, c, "eq15") in g and _ts_k(g[(rate, c, "eq15")]) and _fall(g, rate, c)]
        same = sum(r["swing_s"] is not None and r["time_to_tip_s"] is not None
                   and abs(r["swing_s"] - r["time_to_tip_s"]) < 1e-6 for r in eq)
        lines.append(f"- At {rate} deg/s: t_s = {' / '.join(_f(r['time_to_tip_s']) for r in eq)} s (climbing / "
                     f"descending / lateral), the swing equal to t_s in {same} of {len(eq)}; t_s / kappa against the "
                     f"margin reaching 0 after the judgment without recovery: {_pair_words(g, rate, ORDER)} s (the "
                     f"ratio {_span(ratio, '{:.2f}')}); judged while the platform is "
                     f"{', '.join(sorted({r['platform_at_detection'] or '-' for r in eq}))}, "
                     f"{_span([r['detection_time_s'] - ramp_end[rate] for r in eq if r['detection_time_s'] is not None], '{:.2f}')} s "
                     "after its start-up ramp ended.")
    up = [(yes(not g[k]["tipped"])) for k in g if k[2] == "fixed"]
    lines.append(f"- The fixed 1.5 s swing stays upright in {up.count('yes')} of {len(up)} (rate, case) runs, "
                 f"the Eq. 15 swing in {sum(not g[k]['tipped'] for k in g if k[2] == 'eq15')} of "
                 f"{sum(k[2] == 'eq15' for k in g)}.")
    keys = [(r, c) for r in rates for c in ORDER if (r, c, "eq15") in g and (r, c, "fixed") in g
            and g[(r, c, "eq15")]["margin_after_landing_deg"] is not None
            and g[(r, c, "fixed")]["margin_after_landing_deg"] is not None]
    ma = {k: (g[(*k, "eq15")]["margin_after_landing_deg"], g[(*k, "fixed")]["margin_after_landing_deg"]) for k in keys}
    for rate in rates:
        ks = [k for k in keys if k[0] == rate]
        lines.append(f"- Margin after landing at {rate} deg/s, Eq. 15 / fixed swing: "
                     + ", ".join(f"{k[1]} {ma[k][0]:.1f} / {ma[k][1]:.1f}" for k in ks)
                     + f" deg (the fixed swing higher in {sum(ma[k][1] > ma[k][0] for k in ks)} of {len(ks)}).")
    res = stats.paired([ma[k][0] for k in keys], [ma[k][1] for k in keys], names=("the Eq. 15 swing", "the fixed swing"))
    lines.append(f"- Eq. 15 swing against the fixed swing, margin after landing paired over the {len(keys)} (rate, "
                 f"case) runs: {stats.paired_text(res, 'deg')}.")
    rec += _timing_record(g, rates, ma, up)
    return "\n".join(lines) + "\n", rec


def _timing_record(g: dict, rates: list[str], ma: dict, up: list[str]) -> list:
    R = RECORD["timing"]
    ud = ORDER[:2]
    out = []
    if "10" in rates:
        out += [("t_s at 10 deg/s (s)", R["ts_10"], " / ".join(_f(g[("10", c, "eq15")]["time_to_tip_s"]) for c in ORDER
                                                               if ("10", c, "eq15") in g)),
                ("t_s / kappa against the fall at 10 deg/s, climbing, descending (s)", R["fall_10"], _pair_words(g, "10", ud)),
                ("fixed / Eq. 15 margin at 10 deg/s, climbing, descending (deg)", R["fixed_vs_eq_10"],
                 ", ".join(f"{ma[('10', c)][1]:.1f} / {ma[('10', c)][0]:.1f}" for c in ud if ("10", c) in ma))]
    if "3" in rates:
        out.append(("at 3 deg/s (s)", R["fall_3"], _pair_words(g, "3", ud)))
    if "20" in rates:
        eq = [g[("20", c, "eq15")] for c in ud if ("20", c, "eq15") in g]
        out += [("t_s at 20 deg/s, climbing and descending (s)", R["ts_20"], _span([r["time_to_tip_s"] for r in eq], "{:.2f}")),
                ("the fall (s)", R["fall_20"], _span([_fall(g, "20", c) for c in ud], "{:.2f}")),
                ("the swing (s)", R["swing_20"], _span([r["swing_s"] for r in eq], "{:.2f}")),
                ("Eq. 15 / fixed margin at 20 deg/s, descending (deg)", R["eq_wins_20"],
                 f"{ma[('20', 'descending')][0]:.1f} / {ma[('20', 'descending')][1]:.1f}" if ("20", "descending") in ma else "-")]
    out.append(("fixed swing upright", R["fixed_up"], f"{up.count('yes')} of {len(up)}"))
    return out


def render_timing(datas: list) -> str:
    data = datas[0]
    g = _grid(data) if data else {}
    if not g:
        return missing(TIMING_JSON, TIMING_COMMAND)
    rates = list(dict.fromkeys(k[0] for k in g))
    text, rec = _timing_text(g, rates, _ramp_ends(data))
    return (_timing_table(g, rates) + "\n" + text + _against(rec) + _cost(data, "simulations")
            + "\n" + stats.PAIRED_NOTE + "\n" + progress_note(data, len(current_runs(data))))


# -- the convergence rule ---------------------------------------------------------------------

def _conv_pairs(data: dict) -> list[tuple[str, str, str, dict, dict]]:
    """(step, half, downhill, result at the step, at its half) for every step whose half ran."""
    g = _grid(data)
    steps = [float(x) for x in data["params"]["steps_ms"].split(",") if x.strip()]
    psis = list(dict.fromkeys(k[1] for k in g))
    return [(f"{s:g}", f"{s / 2:g}", psi, g[(f"{s:g}", psi)], g[(f"{s / 2:g}", psi)]) for s in steps for psi in psis
            if (f"{s:g}", psi) in g and (f"{s / 2:g}", psi) in g]


def _d(a: dict, b: dict, k: str) -> float | None:
    return None if a.get(k) is None or b.get(k) is None else abs(a[k] - b[k])


def render_convergence(datas: list) -> str:
    data = datas[0]
    pairs = _conv_pairs(data) if data else []
    if not pairs:
        return missing(CONVERGENCE_JSON, CONVERGENCE_COMMAND)
    rows, lines, rec = [], [], []
    for s, h, psi, a, b in pairs:
        rows.append([f"{s} vs {h}", psi, f"{yes(a['tipped'])} / {yes(b['tipped'])}",
                     f"{_f(a['margin_after_landing_deg'])} / {_f(b['margin_after_landing_deg'])}",
                     f"{_f(a['detection_time_s'])} / {_f(b['detection_time_s'])}",
                     f"{_f(a['time_to_tip_s'])} / {_f(b['time_to_tip_s'])}", yes(convergence_row(a, b)["ok"])])
    for s in dict.fromkeys(p[0] for p in pairs):
        ps = [p for p in pairs if p[0] == s]
        ok = [p for p in ps if convergence_row(p[3], p[4])["ok"]]
        moved = {k: max((x for p in ps if p[3]["tipped"] == p[4]["tipped"] for x in [_d(p[3], p[4], k)] if x is not None),
                        default=None) for k in ("margin_after_landing_deg", "detection_time_s", "time_to_tip_s")}
        out = [f"{p[2]} (tipped at {s} ms: {yes(p[3]['tipped'])}, at {p[1]} ms: {yes(p[4]['tipped'])}; Eq. 15 "
               f"{_f(p[3]['time_to_tip_s'])} / {_f(p[4]['time_to_tip_s'])} s)" for p in ps if p not in ok]
        lines.append(f"- {s} ms against {ps[0][1]} ms: within tolerance in {len(ok)} of {len(ps)} directions; where "
                     f"both agree on tipping the answers moved up to {_f(moved['margin_after_landing_deg'])} deg (margin "
                     f"after landing), {_f(moved['detection_time_s'])} s (detection) and {_f(moved['time_to_tip_s'])} s "
                     f"(Eq. 15); out of tolerance: {', '.join(out) or 'none'}.")
        r = RECORD["convergence"].get(s)
        if r:
            fmt = "{:.2f}" if len(r["margin"].split(".")[-1]) == 2 else "{:.1f}"
            rec += [(f"{s} vs {ps[0][1]} ms ({r['dirs']} in the record), largest margin move (deg)", r["margin"],
                     _f(moved["margin_after_landing_deg"], fmt))]
            rec += [("largest detection move (s)", r["detection"], _f(moved["detection_time_s"]))] if "detection" in r else []
            rec += [("largest Eq. 15 move (s)", r["ts"], _f(moved["time_to_tip_s"])),
                    ("out of tolerance", r["out"], ", ".join(out) or "none")]
    tol = ", ".join(f"{v:g} {k.rsplit('_', 1)[1]} on the {k.rsplit('_', 1)[0].replace('_', ' ')}"
                    for k, v in CONVERGENCE_TOL.items())
    return (md_table(["step vs half (ms)", "downhill (deg)", "tipped", "margin after landing (deg)", "detection (s)",
                      "Eq. 15 t_s (s)", "within tolerance"], rows)
            + f"\nTolerance: {tol}; tipped or not must agree.\n\n" + "\n".join(lines) + "\n" + _against(rec)
            + _cost(data, "simulations") + progress_note(data, len(current_runs(data))))


# -- robustness ---------------------------------------------------------------------------------

def _robust_rows(g: dict) -> list[list[str]]:
    rows = []
    for c in ORDER:
        for n in ("nominal",) + ROBUSTNESS_CASES:
            r = g.get((c, n))
            if r is None:
                continue
            rows.append([c, n, yes(not r["tipped"]), _f(r["margin_after_landing_deg"], "{:.1f}"), _f(r["detection_time_s"]),
                         _f(r["time_to_tip_s"]), _f(r["swing_s"]), _f(r["friction_demand"]),
                         "-" if n == "nominal" else yes(TARGET.met(r))])
    return rows


def _paper_bar(cases: dict | None) -> str:
    """The recovery's and the fixed-swing control's margins after landing in the six cases'
    ledger (climbing, descending: stance 1-3-5) against the paper's bar."""
    if not cases:
        return ""
    res = results_by_name(cases)
    out = []
    for c, name in (("climbing", "runs:y ccw, stance 135"), ("descending", "runs:y cw, stance 135")):
        if name in res:
            fx = next(x["metrics"] for x in res[name]["controls"] if x["name"] == "fixed_swing")
            out.append(f"{c} {_f(res[name]['recovery']['margin_after_deg'], '{:.1f}')} deg with the Eq. 15 swing, "
                       f"{_f(fx['margin_after_landing_deg'], '{:.1f}')} deg with the fixed 1.5 s swing")
    return (f" In the six cases' runs ({CASES_JSON}), margin after landing: " + "; ".join(out) + ".") if out else ""


def render_robustness(datas: list) -> str:
    data, cases = datas[0], datas[1] if len(datas) > 1 else None
    g = _grid(data) if data else {}
    if not g:
        return missing(ROBUST_JSON, ROBUST_COMMAND)
    lines, rec = [], []
    for c in ORDER:
        rs = [g[(c, n)] for n in ROBUSTNESS_CASES if (c, n) in g]
        if not rs:
            continue
        rate = stats.rate_text(stats.success_rate(sum(TARGET.met(r) for r in rs), len(rs)))
        ma = _span([r["margin_after_landing_deg"] for r in rs])
        det = _span([r["detection_time_s"] for r in rs], "{:.2f}")
        inf = [f"{n} (swing {_f(g[(c, n)]['swing_s'])} s, {yes(not g[(c, n)]['tipped']).replace('yes', 'upright').replace('no', 'tipped')})"
               for n in ROBUSTNESS_CASES if (c, n) in g and g[(c, n)]["time_to_tip_s"] is None]
        low = min((n for n in ROBUSTNESS_CASES if (c, n) in g and g[(c, n)]["margin_after_landing_deg"] is not None),
                  key=lambda n: g[(c, n)]["margin_after_landing_deg"], default=None)
        lines.append(f"- {c}: the target met in {rate} (Clopper-Pearson 95 %); margin after landing {ma} deg (lowest: "
                     f"{low}), judged at {det} s; Eq. 15 not finite at the judgment in {', '.join(inf) or 'none'}.")
        k = RECORD["robustness"][c]
        rec += [(f"{c}: met", k[0], f"{sum(TARGET.met(r) for r in rs)}/{len(rs)}"), ("margin (deg)", k[1], ma),
                ("judged (s)", k[2], det)]
    allr = [g[k] for k in g if k[1] != "nominal"]
    dem = _span([g[k]["friction_demand"] for k in g if k[1] != "nominal" and k[0] != "lateral"], "{:.2f}")
    dem_lat = _span([g[k]["friction_demand"] for k in g if k[1] != "nominal" and k[0] == "lateral"], "{:.2f}")
    bar = sum(r["margin_after_landing_deg"] is not None and r["margin_after_landing_deg"] >= PAPER_BAR_DEG for r in allr)
    nom = [(c, g[(c, "nominal")]["platform_tilt_at_landing_deg"]) for c in ORDER if (c, "nominal") in g
           and g[(c, "nominal")].get("platform_tilt_at_landing_deg")]
    lines.append(f"- Friction demand over the re-runs: climbing and descending {dem}, lateral {dem_lat}. The paper's bar (back above {PAPER_BAR_DEG:g} deg after "
                 f"landing) is met by {bar} of the {len(allr)} re-runs.{_paper_bar(cases)}")
    if nom:
        lines.append("- The platform while the margin after landing is read (at the landing / 0.5 s later, deg): "
                     + "; ".join(f"{c} {t[0]:.1f} / {t[1]:.1f}" for c, t in nom) + ".")
    rec.append(("friction demand over the re-runs, climbing and descending", RECORD["robustness"]["demand"], dem))
    return (md_table(["case", "run", "upright", "margin after landing (deg)", "judged (s)", "Eq. 15 t_s (s)", "swing (s)",
                      "friction demand", "target met"], _robust_rows(g))
            + f"\nTarget: {TARGET.text}.\n\n" + "\n".join(lines) + "\n" + _against(rec) + _cost(data, "simulations")
            + progress_note(data, len(current_runs(data))))


FRICTION_SECTIONS = (Section("tipping-friction", (FRICTION_JSON,), render_friction),)
TIMING_SECTIONS = (Section("tipping-timing", (TIMING_JSON,), render_timing),)
CONVERGENCE_SECTIONS = (Section("tipping-convergence", (CONVERGENCE_JSON,), render_convergence),)
ROBUST_SECTIONS = (Section("tipping-robustness", (ROBUST_JSON, CASES_JSON), render_robustness),)

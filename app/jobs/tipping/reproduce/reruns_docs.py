"""docs/tipping.md's "Cliff (Sec. 5.1)" and "Sweep" sections, rendered from the ledgers
app/jobs/tipping/reproduce/reruns.py writes (docs/tipping_cliff.json, docs/tipping_sweep.json): the
tables and every count, rate and comparison the text states."""

from __future__ import annotations

import functools
from collections.abc import Sequence

from app.jobs import stats
from app.jobs.ledger import current_runs, machine_time, results_by_name
from app.jobs.reporting import Section, md_table, missing, num, progress_note, yes
from app.jobs.tipping.evidence import ROBUSTNESS_CASES, recovery_target

SWEEP_JSON = "docs/tipping_sweep.json"
SWEEP_COMMAND = "gaitmend reproduce tipping-sweep --write-docs"
CLIFF_JSON = "docs/tipping_cliff.json"
CLIFF_COMMAND = "gaitmend reproduce tipping-cliff --write-docs"
STANCES = ("135", "246")
LABELS = {"qp": "with the QP", "no_qp": "without the QP", "posture_1hz": "with 1 Hz posture feedback"}
# Issue 12's hand-typed record of the sweep (docs/tipping.md at 06628cb, 2026-12-02; no data
# was committed): its table rows at each tilt (the last column: upright with recovery
# without the QP) and, for the one 1 Hz posture-feedback sweep at 48 deg, its words: upright
# in 19 of 24, holding downhill 90 with 1-3-5 and 270 with 2-4-6 and losing downhill 0 with
# both tripods against the QP alone. The blocks say where this re-run differs from it.
RECORD_ROWS = {40.0: """
| 0 | yes / yes | yes / yes | 4 (a51) / 1 (a24) | 19.2 / 19.2 | yes / yes |
| 30 | no / yes | yes / yes | 4 (a51) / 1 (a24) | 16.4 / 17.0 | yes / yes |
| 60 | no / yes | yes / yes | 2 (a13) / 1 (a24) | 13.4 / 16.6 | yes / yes |
| 90 | no / no | yes / yes | 2 (a13) / 1 (a24) | 13.3 / -90.0 | yes / yes |
| 120 | no / yes | yes / yes | 2 (a13) / 3 (a62) | 15.3 / 21.8 | yes / yes |
| 150 | no / yes | yes / yes | 6 (a35) / 3 (a62) | 18.6 / 27.8 | yes / yes |
| 180 | yes / yes | yes / yes | 6 (a35) / 3 (a62) | 16.1 / 16.1 | yes / yes |
| 210 | yes / no | yes / yes | 6 (a35) / 3 (a62) | 27.8 / 18.6 | yes / yes |
| 240 | yes / no | yes / yes | 6 (a35) / 5 (a46) | 21.8 / 15.3 | yes / yes |
| 270 | no / no | yes / yes | 4 (a51) / 5 (a46) | -90.0 / 13.3 | yes / yes |
| 300 | yes / no | yes / yes | 4 (a51) / 5 (a46) | 12.4 / 13.4 | yes / yes |
| 330 | yes / no | yes / yes | 4 (a51) / 1 (a24) | 17.0 / 16.4 | yes / yes |
""", 48.0: """
| 0 | yes / yes | yes / yes | 4 (a51) / 1 (a24) | 19.2 / 19.2 | yes / yes |
| 30 | yes / yes | yes / yes | 4 (a51) / 1 (a24) | 7.0 / 8.1 | yes / yes |
| 60 | no / yes | yes / no | 2 (a13) / 1 (a24) | 2.2 / 2.4 | yes / yes |
| 90 | yes / yes | no / no | 2 (a13) / 1 (a24) | 4.2 / -180.0 | yes / no |
| 120 | no / yes | yes / yes | 2 (a13) / 3 (a62) | 3.4 / 22.4 | yes / yes |
| 150 | no / yes | yes / yes | 6 (a35) / 3 (a62) | 9.0 / 27.8 | yes / yes |
| 180 | yes / yes | yes / yes | 6 (a35) / 3 (a62) | 17.9 / 17.9 | yes / yes |
| 210 | yes / no | yes / yes | 6 (a35) / 3 (a62) | 27.8 / 8.9 | yes / yes |
| 240 | yes / no | yes / yes | 6 (a35) / 5 (a46) | 22.4 / 3.5 | yes / yes |
| 270 | yes / yes | no / no | 4 (a51) / 5 (a46) | -90.0 / 4.1 | no / yes |
| 300 | yes / no | yes / yes | 4 (a51) / 5 (a46) | 1.9 / 2.0 | yes / yes |
| 330 | yes / yes | yes / yes | 4 (a51) / 1 (a24) | 8.2 / 7.0 | yes / yes |
"""}
RECORD_POSTURE_48 = {"upright": 19, "holds": [(90.0, "135"), (270.0, "246")], "loses": [(0.0, "135"), (0.0, "246")]}
TARGET = recovery_target(0.0)  # the job's default target: upright, margin after landing >= 0


def _span(values: Sequence[float | None], fmt: str = "{:.1f}") -> str:
    v = [x for x in values if x is not None]
    if not v:
        return "-"
    lo, hi = fmt.format(min(v)), fmt.format(max(v))
    return lo if lo == hi else f"{lo}-{hi}"


def _cost(runs: list[dict]) -> str:
    wall, cpu = sum(r["wall_s"] for r in runs), sum(r["cpu_s"] for r in runs)
    loads = [r["result"]["load_after"] for r in runs if "load_after" in r["result"]]
    return (f"{len(runs)} directions, {wall:.0f} s wall, {cpu:.0f} s CPU, load average {_span(loads)} at their ends "
            f"on {runs[0]['result'].get('cores', '?')} cores")


# -- the sweep ----------------------------------------------------------------------------------

def sweep_grid(data: dict) -> dict[float, dict[str, dict[float, dict[str, dict]]]]:
    """{tilt: {variant or "no_recovery": {downhill: {stance: row}}}} of the current runs."""
    out: dict = {}
    for name, res in results_by_name(data).items():
        if name.startswith("trace:"):
            continue
        tilt, variant, psi = name.split(":")
        cell = out.setdefault(float(tilt), {}).setdefault(variant, {}).setdefault(float(psi), {})
        for row in res["rows"]:
            cell[row["stance"]] = row
    return out


def _pairs(a: dict, b: dict) -> list[tuple[float, str]]:
    """The (downhill, stance) runs both variants have."""
    return [(psi, s) for psi in sorted(a) if psi in b for s in STANCES if s in a[psi] and s in b[psi]]


def _up(cell: dict, psi: float, s: str) -> int:
    return 0 if cell[psi][s]["tipped"] else 1


def _runs_named(keys: list[tuple[float, str]]) -> str:
    return ", ".join(f"{psi:g} with {s[0]}-{s[1]}-{s[2]}" for psi, s in keys) or "none"


def _table_rows(grid: dict) -> tuple[list[str], list[list[str]]]:
    """The sweep table at one tilt: (columns, rows), one row per downhill direction."""
    base = grid.get("no_recovery", {})
    variants = [v for v in LABELS if v in grid and v != "qp"]
    qp = grid.get("qp", {})
    rows = []
    for psi in sorted(set(base) | set(qp)):
        b, q = base.get(psi, {}), qp.get(psi, {})

        def both(f, cell) -> str:
            return " / ".join(f(cell[s]) if s in cell else "-" for s in STANCES)

        rows.append([f"{psi:g}", both(lambda r: yes(r["tipped"]), b), both(lambda r: yes(not r["tipped"]), q),
                     both(lambda r: f"{r['leg']} ({r['edge']})" if r["leg"] else "none", q),
                     both(lambda r: num(r["margin_after_deg"], "{:.1f}"), q)]
                    + [both(lambda r: yes(not r["tipped"]), grid[v].get(psi, {})) for v in variants])
    return (["downhill (deg)", "tips without recovery (135 / 246)", "upright with recovery (135 / 246)",
             "leg caught (135 / 246)", "margin after landing (135 / 246, deg)"]
            + [f"upright with recovery, {LABELS[v].removeprefix('with ')} (135 / 246)" for v in variants], rows)


def _count(rows: list[list[str]], col: int) -> tuple[int, int]:
    """(yes, yes or no) over both tripods of column ``col``."""
    cells = [c for r in rows for c in r[col].split(" / ")]
    return cells.count("yes"), sum(c in ("yes", "no") for c in cells)


def _against_record(tilt: float, columns: list[str], rows: list[list[str]], grid: dict) -> str:
    """This re-run against issue 12's hand-typed record (``RECORD_ROWS``), row by row and
    in counts."""
    text = RECORD_ROWS.get(tilt)
    if text is None:
        return ""
    rec = {r[0]: r for r in ([c.strip() for c in line.strip("|").split("|")] for line in text.strip().splitlines())}
    nq = next((i for i, c in enumerate(columns) if "without the QP" in c), None)
    cols = [0, 1, 2, 3, 4] + ([nq] if nq is not None else [])
    differ = [r[0] for r in rows if r[0] not in rec or [r[i] for i in cols] != rec[r[0]][:len(cols)]]
    words = {1: "tip without recovery", 2: "stay up with recovery", 5: "stay up with recovery without the QP"}
    counts = "; ".join(f"{words[i]}: {_count(rows, c)[0]} of {_count(rows, c)[1]} here, "
                       f"{_count(list(rec.values()), i)[0]} of {_count(list(rec.values()), i)[1]} in the record"
                       for i, c in ((1, 1), (2, 2), (5, nq)) if c is not None)
    out = (f"- Against issue 12's hand-typed record of this sweep (2026-12-02, no data committed): "
           f"{len(rows) - len(differ)} of the {len(rows)} directions here (the record has {len(rec)}) the same in "
           "every cell of the record's columns"
           f"{' (differing: ' + ', '.join(differ) + ')' if differ else ''}; {counts}.")
    if tilt == 48.0 and "posture_1hz" in grid:
        post, qp = grid["posture_1hz"], grid["qp"]
        keys = _pairs(post, qp)
        holds = [k for k in keys if _up(post, *k) > _up(qp, *k)]
        loses = [k for k in keys if _up(post, *k) < _up(qp, *k)]
        same = holds == RECORD_POSTURE_48["holds"] and loses == RECORD_POSTURE_48["loses"]
        out += (f" With 1 Hz posture feedback: upright in {sum(_up(post, *k) for k in keys)} of {len(keys)} here, "
                f"{RECORD_POSTURE_48['upright']} of 24 in the record; the runs it holds and loses against the QP "
                f"alone are {'' if same else 'not '}the record's.")
    return out + "\n"


def _rate(cell: dict, keys: list[tuple[float, str]], up: bool) -> str:
    k = sum(_up(cell, psi, s) == up for psi, s in keys)
    return stats.rate_text(stats.success_rate(k, len(keys)))


def _versus(a: dict, b: dict, names: tuple[str, str]) -> str:
    """The paired comparison of staying upright, ``a`` (the method) against ``b`` (the
    control), both {downhill: {stance: row}}, with the runs where they differ."""
    keys = _pairs(a, b)
    res = stats.paired([_up(a, *k) for k in keys], [_up(b, *k) for k in keys], names=names)
    only_a = [k for k in keys if _up(a, *k) > _up(b, *k)]
    only_b = [k for k in keys if _up(a, *k) < _up(b, *k)]
    return (f"upright (1) or not (0), paired over {len(keys)} (downhill, tripod): {stats.paired_text(res)}; upright "
            f"only {names[0]} in {len(only_a)} ({_runs_named(only_a)}), only {names[1]} in {len(only_b)} "
            f"({_runs_named(only_b)})")


def _mirror(cell: dict) -> tuple[int, int]:
    """(agreeing, compared): stance 1-3-5 at downhill psi against 2-4-6 at 360 - psi (tipped)."""
    keys = [(psi, s) for psi in cell for s in STANCES if s in cell[psi]]
    pairs = [(k, ((360.0 - k[0]) % 360.0, STANCES[1 - STANCES.index(k[1])])) for k in keys if k[1] == "135"]
    pairs = [(a, m) for a, m in pairs if m[0] in cell and m[1] in cell[m[0]]]
    return sum(cell[a[0]][a[1]]["tipped"] == cell[m[0]][m[1]]["tipped"] for a, m in pairs), len(pairs)


def _tilt_text(grid: dict, tilt: float) -> str:
    base, qp = grid.get("no_recovery", {}), grid.get("qp", {})
    keys = _pairs(base, qp)
    if not keys:
        return ""
    lines = [f"- At {tilt:g} deg the robot tips without recovery in {_rate(base, keys, False)} of the runs "
             f"(Clopper-Pearson 95 %) and stays upright with recovery in {_rate(qp, keys, True)}"
             + "".join(f"; {LABELS[v]} in {_rate(grid[v], _pairs(base, grid[v]), True)}"
                       for v in LABELS if v in grid and v != "qp") + ".",
             "- Recovery against none: " + _versus(qp, base, ("with recovery", "without recovery")) + "."]
    lines += [f"- Recovery {LABELS[v]} against recovery {LABELS['qp']}: "
              + _versus(grid[v], qp, (LABELS[v], LABELS["qp"])) + "." for v in ("no_qp", "posture_1hz") if v in grid]
    miss = [(psi, s) for psi, s in _pairs(qp, qp) if not qp[psi][s]["tipped"]
            and not TARGET.met({"tipped": False, "margin_after_landing_deg": qp[psi][s]["margin_after_deg"]})]
    lines.append(f"- Upright with recovery ({LABELS['qp']}) but with the margin 0.5 s after the caught leg lands below "
                 f"0 (a miss of the job's target): {len(miss)} ({_runs_named(miss)}).")
    agree = [_mirror(grid[v]) for v in ("no_recovery", "qp") if v in grid]
    lines.append(f"- Mirror symmetry (stance 1-3-5 at downhill psi against 2-4-6 at 360 - psi, tipped or not, "
                 f"without and with recovery): the same in {sum(a for a, _ in agree)} of {sum(n for _, n in agree)} "
                 "mirrored pairs.")
    return "\n".join(lines) + "\n"


def _d1(v: float) -> str:
    return f"{round(v, 1) + 0.0:.1f}"  # no "-0.0"


TRACE_SAMPLES = 6  # samples of a traced run the text shows (from the first landing, 1 s apart)


def _trace_words(r: dict) -> str:
    """One traced run in words: the landings, the body's tilt off the platform and the
    margin after the first, and how it ended."""
    adj = [a for a in r["adjustments"] if a["land_time_s"] is not None]
    if not adj:
        return "no leg landed"
    a = adj[0]
    shown = [x for x in r["samples"] if r["tipped_at_s"] is None or x["time_s"] <= r["tipped_at_s"] + 1.0][:TRACE_SAMPLES]
    series = ", ".join(f"{_d1(x['body_off_platform_deg'])} / {_d1(x['margin_deg'])}" for x in shown)
    out = (f"judged at {a['detect_time_s']:.2f} s, leg {a['leg']} lands at {a['land_time_s']:.2f} s (margin {num(a['margin_after_landing_deg'], '{:.1f}')} deg "
           f"0.5 s later); body off the platform / margin (deg) at {shown[0]['time_s']:.2f} s and every "
           f"second after: {series}")
    nxt = adj[1] if len(adj) > 1 else None
    second = "" if nxt is None else f" the second adjustment (leg {nxt['leg']}) lands at {nxt['land_time_s']:.2f} s"
    if r["tipped"]:
        return out + f"; it tips at {r['tipped_at_s']:.2f} s" + (
            f", before{second}" if nxt and nxt["land_time_s"] > r["tipped_at_s"] else (f"; {second}" if second else ""))
    return out + (f";{second} (margin {num(nxt['margin_after_landing_deg'], '{:.1f}')} deg 0.5 s later)" if nxt else "") \
        + "; it stays upright"


def _traces(data: dict, tilt: float) -> str:
    res = results_by_name(data)
    out = []
    for name in res:
        parts = name.split(":")
        if parts[0] != "trace" or float(parts[1]) != tilt or parts[2] != "qp":
            continue
        other = ":".join(["trace", parts[1], "no_qp", *parts[3:]])
        psi, st = parts[3], parts[4]
        text = (f"- Traced: downhill {psi} with {st[0]}-{st[1]}-{st[2]} ({SWEEP_COMMAND.split(' --')[0]} "
                f"--traces {parts[1]}:{psi}:{st}), {LABELS['qp']}: {_trace_words(res[name])}.")
        if other in res:
            text += f" {LABELS['no_qp'][0].upper() + LABELS['no_qp'][1:]}: {_trace_words(res[other])}."
        out.append(text)
    return "\n".join(out) + "\n" if out else ""


def render_sweep_tilt(tilt: float, datas: list, note: bool = False) -> str:
    """The sweep at one final tilt: its table, counts, paired comparisons and machine time;
    ``note``: with the words on the paired statistics."""
    data = datas[0]
    if data is None:
        return missing(SWEEP_JSON, SWEEP_COMMAND)
    grid = sweep_grid(data).get(tilt)
    if not grid:
        return f"*No {tilt:g} deg rows yet: `{SWEEP_COMMAND}` writes them to {SWEEP_JSON}.*\n"
    runs = [r for r in current_runs(data) if r["name"].startswith(f"{tilt:g}:")]  # the traces' time is their own
    by = {v: [r for r in runs if r["name"].split(":")[1] == v] for v in grid}
    cost = "; ".join(f"{'recovery ' + LABELS[v] if v in LABELS else 'without recovery'}: {_cost(rs)}"
                     for v, rs in by.items())
    cost_note = f"\nMachine time at {tilt:g} deg (a ledger run is one direction, both tripods): {cost}.\n"
    columns, rows = _table_rows(grid)
    return (md_table(columns, rows) + "\n" + _tilt_text(grid, tilt) + _traces(data, tilt) + _against_record(tilt, columns, rows, grid)
            + cost_note + ("\n" + stats.PAIRED_NOTE + "\n" if note else "")
            + progress_note(data, len(current_runs(data))))


def render_sweep(datas: list) -> str:
    data = datas[0]
    tilts = sorted(sweep_grid(data)) if data else []
    if not tilts:
        return missing(SWEEP_JSON, SWEEP_COMMAND)
    return "\n".join(render_sweep_tilt(t, datas, note=t == tilts[-1]) for t in tilts)


# -- the cliff ----------------------------------------------------------------------------------

def _cliff_row(name: str, r: dict) -> list[str]:
    return [name, yes(not r["tipped"]), num(r.get("tipped_at_s"), "{:.2f}"), num(r["detection_time_s"]),
            num(r["leg"], "{:d}"), num(r["swing_s"]), num(r["time_to_tip_s"]), num(r["margin_after_landing_deg"], "{:.1f}"),
            num(r["final_margin_deg"], "{:.1f}"), num(r["max_slip_m"], "{:.3f}")]


def render_cliff(datas: list) -> str:
    data = datas[0]
    res = results_by_name(data) if data else {}
    if "no_recovery" not in res or "recovery" not in res:
        return missing(CLIFF_JSON, CLIFF_COMMAND)
    base, rec = res["no_recovery"], res["recovery"]
    ev = [(n, res[n]) for n in [f"control:{c}" for c in ("no_qp", "position_stance", "fixed_swing")]
          + [f"robust:{c}" for c in ROBUSTNESS_CASES] if n in res]
    table = md_table(["run", "upright", "tipped at (s)", "judged (s)", "leg", "swing (s)", "Eq. 15 t_s (s)",
                      "margin after landing (deg)", "final margin (deg)", "foot slip (m)"],
                     [_cliff_row(n, r) for n, r in [("no recovery", base), ("recovery", rec)] + ev])
    rob = [r for n, r in ev if n.startswith("robust:")]
    ctl = [r for n, r in ev if n.startswith("control:")]
    t_s = [r["time_to_tip_s"] for r in rob]
    fw, ts = rec["flat_window_s"], rec["time_to_tip_s"]
    text = (f"\nOn flat ground (from the first step at {fw[0]:g} s to 1 s before the margin first falls under 20 deg) "
            f"the margin cycles in {_span(base['flat_margin_deg'])} deg. It falls under 20 deg at "
            f"{num(base['first_below_threshold_s'])} s. Without recovery it reaches {base['min_margin_deg']:.1f} deg and "
            f"the body rolls more than 10 deg toward the void (tipped at {num(base['tipped_at_s'])} s); at the end it "
            f"stands {base['final_body_tilt_deg']:.1f} deg off level (the next tripod landed and levelled it), its feet "
            f"having slid up to {base['max_slip_m']:.2f} m. With recovery the gait stops at the judgment "
            f"({num(rec['detection_time_s'])} s), leg {rec['leg']} (edge {rec['tipping_edge']}) is placed at "
            f"({', '.join(f'{x:.2f}' for x in rec['foothold_body_m'])}) m (body frame) in a {num(rec['swing_s'])} s swing, "
            f"landing {num(rec['adjustment_time_s'])} s after the judgment; Eq. 15's time "
            f"{'was not finite' if ts is None else f'was {ts:.2f} s'}; "
            f"the margin is {rec['margin_after_landing_deg']:.1f} deg 0.5 s after the landing and "
            f"{rec['final_margin_deg']:.1f} deg at the end, the body {rec['final_body_tilt_deg']:.1f} deg off level, "
            f"the feet having slid up to {rec['max_slip_m']:.2f} m.\n")
    if ctl:
        text += (f"\nControls: upright in {sum(not r['tipped'] for r in ctl)} of {len(ctl)} (margin after landing "
                 f"{_span([r['margin_after_landing_deg'] for r in ctl])} deg).")
    if rob:
        met = sum(TARGET.met(r) for r in rob)
        text += (f" Robustness: the target ({TARGET.text}) met in {stats.rate_text(stats.success_rate(met, len(rob)))} "
                 f"(Clopper-Pearson 95 %), margin after landing {_span([r['margin_after_landing_deg'] for r in rob])} "
                 f"deg, judged at {_span([r['detection_time_s'] for r in rob], '{:.2f}')} s, Eq. 15's time "
                 f"{_span(t_s, '{:.2f}')} s where finite (not finite in {sum(t is None for t in t_s)} of {len(rob)}).")
    mt = machine_time(data)
    loads = [r["result"]["load_after"] for r in current_runs(data)]
    text += (f"\n\nMachine time: {mt['runs']} simulations, {mt['wall_s']:.0f} s wall, {mt['cpu_s']:.0f} s CPU (load "
             f"average {_span(loads)} at their ends, beside other work).\n")
    return table + text + progress_note(data, len(current_runs(data)))


CLIFF_SECTIONS = (Section("tipping-cliff", (CLIFF_JSON,), render_cliff),)
SWEEP_SECTIONS = (Section("tipping-sweep-40", (SWEEP_JSON,), functools.partial(render_sweep_tilt, 40.0)),
                  Section("tipping-sweep-48", (SWEEP_JSON,), functools.partial(render_sweep_tilt, 48.0, note=True)))

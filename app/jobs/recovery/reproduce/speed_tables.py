"""The speed page's tables of what was measured, one per part: the step profile, the physics
settings, the coarse step, the alternatives, the cut walks' check and control, the speed
cap, the runs and their hosts."""

from __future__ import annotations

import json
import math
import statistics

from app.core.host import machine_text
from app.jobs.recovery.reproduce.speed_configs import SCENARIOS, _config, _labels, _paper_fitness


# -- the page ------------------------------------------------------------------------------------

def _name(lost) -> str:
    return ("legs " if len(lost) > 1 else "leg ") + " & ".join(str(l) for l in lost)


def _spread(values: list[float], fmt: str = "{:.1f}") -> str:
    if not values:
        return "-"
    return f"{fmt.format(statistics.median(values))} [{fmt.format(min(values))}, {fmt.format(max(values))}]"


def profile_markdown(block: dict) -> list[str]:
    """The step profile as measured (the machine's cores where the block recorded them)."""
    cores = f" on {block['cores']} cores" if block.get("cores") else ""
    cols = ["step", "position", "pos_kinematics", "pos_inertia", "col_broad", "col_narrow", "pos_make", "velocity",
            "actuation", "constraint", "advance"]
    out = [f"Step profile (MuJoCo's timers, us per step with the timers on, single thread, each stage's fastest of "
           f"7 rounds of 1000 steps; load {block['load']:.1f}{cores} while measured, so compare "
           "the shares more than the absolute times). The recovery robot stands in its first pose; the other "
           "built-in robots as their kinds build them, without control (a first look only):", "",
           "| robot | damage | " + " | ".join(cols) + " | contacts | rows | solver iterations |",
           "|---" * (len(cols) + 5) + "|"]
    for r in block["rows"]:
        t = r["us_per_step"]
        out.append(f"| {r['robot']} | {_name(r['damage']) if r['damage'] else 'none'} | "
                   + " | ".join(f"{t[c]:.1f}" for c in cols)
                   + f" | {r['contacts']:.1f} | {r['constraint_rows']:.1f} | {r['solver_iterations']:.2f} |")
    return out + [""]


def variants_markdown(blocks: list[dict]) -> list[str]:
    loads = " | ".join(f"speed-up at load {b['load']:.1f}" for b in blocks)
    ref = ", ".join(f"{b['reference_us_per_step']:.1f}" for b in blocks)
    last = blocks[-1]
    out = [f"Physics settings tried on the default damaged model (legs 1 & 6): single-thread CPU time per step "
           f"against the model as it was then (MuJoCo's broad phase and island discovery, before the two changes "
           f"above; {ref} us in the measurements below), each measured {len(blocks)} time(s) "
           f"on the shared machine (the unchanged copy shows the noise), and the {last['answers']} documented "
           "answers re-simulated at the default step with the setting. At these loads none was both faster beyond "
           "the noise and free of changes to the answers; no island discovery, measured again on an idle machine "
           "with the changes table's method, is the one adopted since (its row above):", "",
           f"| setting | {loads} | documented answers | largest change forward / lateral (cm) / yaw (deg) |",
           "|---" * (len(blocks) + 3) + "|"]
    for i, r in enumerate(last["rows"]):
        ups = " | ".join(f"{b['rows'][i]['speedup']:.2f}" for b in blocks)
        out.append(f"| {r['variant']} | {ups} | {'bit-identical' if r['identical'] else 'move'} | "
                   f"{r['max_forward_cm']:.1f} / {r['max_lateral_cm']:.1f} / {r['max_yaw_deg']:.1f} |")
    return out + [""]


def coarse_markdown(rows: list[dict]) -> list[str]:
    cfg = {k: v for k, v in _config(rows[0]).items() if k != "generations"}
    out = [f"Coarse-to-fine, first half: the equal-quality configuration of its time (`{json.dumps(cfg)}`) searched "
           "at twice the default step for twice the generations (about as many steps), its answer judged at the "
           "default step. The refinement at "
           "the default step would have to recover more F than searching at the default step from the start gives "
           "for the same steps, so coarse-to-fine was not built:", "",
           "| damage | seed | F at the coarse step | F at the default step | target at the coarse step / default "
           "step | yaw (deg) at the default step | steps |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["at_default_step"]
        out.append(f"| {_name(r['lost_legs'])} | {r['seed']} | {r['fitness']:.2f} | {d['fitness']:.2f} | "
                   f"{'yes' if r['target_met'] else 'no'} / {'yes' if d['target_met'] else 'no'} | "
                   f"{d['metrics']['yaw_f_deg']:.1f} | {r['sim_steps']:,} |")
    return out + [""]


def alternatives_markdown(rows: list[dict], table2: list[dict]) -> list[str]:
    """Per damage and configuration: F over its seeds against the paper DE's on the same
    seeds, and its answers meeting the target at the default step and at half of it."""
    out = ["The equal-quality configuration and every other one tried, on the damages they were run on (walks: its "
           "budget; steps: what its runs simulated, fewer with short walks; the paper DE's F: its runs on this page, "
           "else docs/table2.json's for that seed; a configuration counts as equal quality when its median F over "
           "the seeds is at least the paper DE's median over the same seeds and its answers meet the target also at "
           "half the step):", "",
           "| damage | configuration | walks (steps, median) | F, median [range] (seeds) | paper DE F on those seeds | "
           ">= paper, same seed | target met (also at half the step) |", "|---|---|---|---|---|---|---|"]
    configs = _labels()
    rows = [r for r in rows if "lost_legs" in r]  # searches only (not the bench, profile or variants)
    for lost in SCENARIOS:
        paper = _paper_fitness(rows, lost, table2)
        for part, cfg in configs:
            got = [r for r in rows if r["part"] == part and tuple(r["lost_legs"]) == lost]
            if not got or not any(r["part"].startswith("alt_") and tuple(r["lost_legs"]) == lost for r in rows):
                continue
            pf = [paper[r["seed"]] for r in got if r["seed"] in paper]
            wins = sum(r["fitness"] >= paper[r["seed"]] for r in got if r["seed"] in paper)
            s = cfg["search"]
            steps = statistics.median(r["sim_steps"] for r in got)
            out.append(f"| {_name(lost)} | `{json.dumps(cfg)}` | {s['population'] * (s['generations'] + 1)} "
                       f"({steps / 1e6:.2f} M) | "
                       f"{_spread([r['fitness'] for r in got], '{:.2f}')} ({len(got)}) | "
                       f"{_spread(pf, '{:.2f}')} ({len(pf)}) | {wins} of {len(pf)} | "
                       f"{sum(r['target_met'] for r in got)} ({sum(bool(r['half_step_met']) for r in got)}) of "
                       f"{len(got)} |")
    return out + [""]


def check_markdown(rows: list[dict]) -> list[str]:
    same = sum(bool(r["identical_to_documented"]) for r in rows)
    saved = sum(r["cut_steps_saved"] for r in rows) / max(1, sum(r["sim_steps"] + r["cut_steps_saved"] for r in rows))
    out = [f"Cut walks on every documented damage: the nominal answers of docs/recovery_robust_w20.json (DE 12 x 12, "
           f"1 ms, weights [1, 20, 10, 100, 100], every feasible 1- and 2-leg loss) searched again with "
           f"`search.cut_walks`: {same} of {len(rows)} answers are the documented ones bit for bit; the cut walks "
           f"saved {100 * saved:.1f} % of the steps.", "",
           "| damage | same answer | steps | steps saved | walks cut |", "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {_name(r['lost_legs'])} | {'yes' if r['identical_to_documented'] else '**no**'} | "
                   f"{r['sim_steps']:,} | {r['cut_steps_saved']:,} | {r.get('walks_cut', '-')} |")
    return out + [""]


def _close(a: float | None, b: float) -> bool:
    return a is not None and math.isclose(a, b, rel_tol=1e-9)


def control_markdown(rows: list[dict]) -> list[str]:
    """The random-search control with cut walks against full walks, run by run."""
    out = [f"The random-search control with cut walks (`controls.cut_walks`, on by default): the control of the "
           f"paper-size job (30 candidates x 61 generations on its own stream of the job's seed) run on the same job "
           f"with cut walks, then with full walks. {sum(r['identical'] for r in rows)} of {len(rows)} have the same "
           f"best (parameters and F) bit for bit. Table II's F: the control's F in docs/table2.json for that seed. "
           f"{sum(_close(r['documented_fitness'], r['cut']['fitness']) for r in rows)} of "
           f"{sum(r['documented_fitness'] is not None for r in rows)} agree with the cut control's to 1e-9 (relative) "
           f"and differ from the 12th digit on: numpy's AVX-512 math kernels on this host round the walk's metrics "
           f"differently (re-scored with them switched off, `NPY_DISABLE_CPU_FEATURES=\"AVX512_ICL X86_V4\"`, "
           f"these answers give Table II's F bit for bit). The rows that differ more were run before the control got "
           f"its own seed stream (commit 7caa61f).", "",
           "| damage | seed | same best | F | steps cut / full | walks cut | wall cut / full (s) | load | "
           "Table II's F |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        doc = r["documented_fitness"]
        cut, full = r["cut"], r["full"]
        out.append(f"| {_name(r['lost_legs'])} | {r['seed']} | {'yes' if r['identical'] else '**no**'} | "
                   f"{cut['fitness']:.2f} | {cut['sim_steps']:,} / {full['sim_steps']:,} | {cut['walks_cut']} | "
                   f"{cut['wall_s']:.0f} / {full['wall_s']:.0f} | {r['load']:.1f} | "
                   f"{'-' if doc is None else f'{doc:.2f}'} |")
    return out + [""]


def cap_markdown(rows: list[dict]) -> list[str]:
    from app.jobs.recovery.evaluate import CUT_SPEED_FACTOR

    top = max(r["max_ratio"] for r in rows)
    out = [f"Cut walks' speed cap: over {sum(r['walkers'] for r in rows)} uniform random walks that did not fall, the "
           f"fastest mean forward speed over the rest of a walk (from any chunk's end) was {top:.2f} times the gait's "
           f"nominal speed (step length per period); the rule caps it at {CUT_SPEED_FACTOR:g} times.", "",
           "| damage | walks (of candidates) | largest ratio | 99th percentile |", "|---|---|---|---|"]
    out += [f"| {_name(r['lost_legs'])} | {r['walkers']} ({r['candidates']}) | {r['max_ratio']:.2f} | "
            f"{r['p99_ratio']:.2f} |" for r in rows]
    return out + [""]


def runs_markdown(rows: list[dict]) -> list[str]:
    out = ["| part | damage | seed | F | target met (half step) | stop | generations | evaluations | steps | steps "
           "saved by cut walks | time to target (s) | wall (s) | load | host |", "|---" * 14 + "|"]
    for r in sorted(rows, key=lambda r: (r["part"], SCENARIOS.index(tuple(r["lost_legs"]))
                                         if tuple(r["lost_legs"]) in SCENARIOS else 9, r["seed"])):
        ttt = r.get("time_to_target_s")
        same = r.get("identical_to_documented")
        out.append(f"| {r['part']} | {_name(r['lost_legs'])} | {r['seed']} | {r['fitness']:.2f}"
                   f"{'' if same is None else (' (= docs)' if same else ' (**differs from docs**)')} | "
                   f"{'yes' if r['target_met'] else 'no'} ({'yes' if r['half_step_met'] else 'no'}) | "
                   f"{r['search']['stop_reason']} | {r['search']['generations_run']} | {r['evaluations']} | "
                   f"{r['sim_steps']:,} | {r['cut_steps_saved']:,} | {'-' if ttt is None else f'{ttt:.1f}'} | "
                   f"{r['wall_s']:.0f} | {r['load']:.1f} | {_host(r)} |")
    return out + [""]


def _host(row: dict) -> str:
    """The CPU a run ran on, where it was recorded (wall times differ between hosts)."""
    m = row.get("machine")
    return "not recorded" if m is None else machine_text(m, cores=False)

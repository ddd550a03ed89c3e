"""Issue 24's measurement: the four documented Table II answers (docs/table2.json, the default
step), each walked open loop (the paper), closed loop (the same gait with the heading and
drift correction of the spec's defaults) and closed loop with balance (issue 47: the same
law plus the balance correction, BALANCE), on the nominal model, the seven named cases and
held-out random models drawn from the stated ranges with the answer's seed (the held-out
stream). Evaluations only, no search: `gaitmend reproduce recovery-closed-loop --write-docs`.
Each answer's run is appended to docs/recovery_closed_loop.json the moment it ends (a
re-run skips those already there at this code version)."""

from __future__ import annotations

import dataclasses
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger, current_runs, machine_time
from app.jobs.reporting import md_table, missing
from app.jobs.stats import wilson  # noqa: F401  (the recovery pages import it from here too)

JSON = "docs/recovery_closed_loop.json"
COMMAND = "gaitmend reproduce recovery-closed-loop --write-docs"
SCIENCE = ("app/jobs/recovery/evaluate.py", "app/jobs/recovery/closedloop.py", "app/jobs/recovery/gait_controller.py",
           "app/jobs/recovery/cases.py", "app/jobs/recovery/robust.py", "app/jobs/recovery/metrics.py",
           "app/jobs/recovery/trajectory.py", "app/jobs/recovery/sequences.py", "app/jobs/recovery/spec.py",
           "app/robots/hexapod/__init__.py", "app/robots/hexapod/entry.py", "app/robots/ik.py", "app/sim/perturb.py")
KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "fell")
# Issue 24's "done when", per damage: the closed-loop answer keeps the target in at least 6
# of the 7 named cases and in at least 80 % of at least 20 held-out models.
DONE_NAMED, DONE_HELD_OUT = 6, 0.8
# The balance arm: full levelling by the proportional term (each tip moves by the height the
# trunk over it is off level), at the spec's default limit; fixed before it was measured here.
BALANCE = {"balance_gain": 1.0, "balance_integral_gain": 0.0}
DRIVES = (("open_loop", "open loop"), ("closed_loop", "closed loop"), ("balance", "closed loop + balance"))


class LoopParams(BaseModel):
    held_out: int = Field(40, ge=20, le=200, description="held-out random models per answer (the issue asks >= 20)")
    update: str = Field("period", pattern="^(period|phase)$", description="the correction's update: per gait period "
                                                                           "or per phase")
    json_out: Path | None = Field(Path(JSON), description="the ledger: each answer's run is appended when it ends")



def _shown(name: str) -> str:
    """A ledger name ("legs 1-6", "legs 4") as the page says it ("legs 1 & 6", "leg 4")."""
    shown = name.replace("-", " & ")
    return shown if "&" in shown else shown.replace("legs ", "leg ", 1)

def table2_answers(docs: Path = Path("docs")) -> list[dict]:
    """The Table II answers at the default step, one per damage: seed 0's (the page's documented
    answer; Table II's further seeds are its spread, not more answers to walk here)."""
    from app.jobs.recovery.spec import RecoverySpec

    dt = RecoverySpec().sim.timestep_s
    rows = json.loads((docs / "table2.json").read_text())
    return [r for r in rows if r["timestep_s"] == dt and r["seed"] == 0]


def walk_both_ways(lost: list[int], params: dict[str, float], seed: int, held_out_n: int, update: str) -> dict:
    """One answer open loop, closed loop and closed loop with balance on the nominal model, the
    named cases and the held-out set: {drive: {"nominal", "cases": {name: ...}, "held_out":
    [...]}} (metrics and target), the laws and the held-out draws."""
    from app.jobs.recovery.cases import HELD_OUT_STREAM, draw_models, random_models, walking_cases
    from app.jobs.recovery.robust import case_models
    from app.jobs.recovery.run import sim_config, sim_model
    from app.jobs.recovery.sequences import plan_hexapod
    from app.jobs.recovery.spec import RecoverySpec
    from app.robots.catalog import get_robot

    spec = RecoverySpec.parse({"damage": {"lost_legs": lost}, "control": {"mode": "closed_loop", "update": update}})
    balanced = RecoverySpec.parse({"damage": {"lost_legs": lost},
                                   "control": {"mode": "closed_loop", "update": update} | BALANCE})
    robot = get_robot(spec.robot)
    mspec, model = sim_model(spec, robot)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    cases = walking_cases(robot.geometry.total_mass)
    draws = draw_models(seed, held_out_n, HELD_OUT_STREAM)
    models = [model] + case_models(mspec, model, cases) + random_models(mspec, draws, robot.geometry.total_mass)
    x = np.array([list(params.values())])
    out = {"law": None, "draws": draws}
    for mode, cfg in (("open_loop", sim_config(spec, open_loop=True)), ("closed_loop", sim_config(spec)),
                      ("balance", sim_config(balanced))):
        out[mode] = walked(robot, models, seq, cfg, x, cases, spec.sim.duration_s)
        if mode == "closed_loop":
            out["law"] = cfg.law.as_dict()
        if mode == "balance":
            out["balance_law"] = cfg.law.as_dict()
    return out


def walked(robot, models: list, seq, cfg, x: np.ndarray, cases: list, walk_s: float) -> dict:
    """One answer ``x`` (1, D) on ``models`` (the nominal model, then one per named case in
    ``cases``, then the held-out models) in one rollout call, each walk judged by the target:
    {"nominal", "cases": {name: ...}, "held_out": [...], "wall_s"} (KEEP metrics, target_met)."""
    from app.jobs.recovery.metrics import target_met
    from app.jobs.recovery.robust import MultiModelEvaluator

    t0 = time.perf_counter()
    ev = MultiModelEvaluator(robot, models, seq, cfg)
    try:
        m = ev.evaluate_all(x).metrics
    finally:
        ev.close()
    rows = []
    for k in range(len(models)):
        mk = {key: (bool(v[0, k]) if key == "fell" else float(v[0, k])) for key, v in m.items() if key in KEEP}
        rows.append(mk | {"target_met": target_met(mk, walk_s)})
    return {"nominal": rows[0], "cases": {c.name: rows[1 + i] for i, c in enumerate(cases)},
            "held_out": rows[1 + len(cases):], "wall_s": round(time.perf_counter() - t0, 2)}


def run_loop_check(p: LoopParams, log: Callable[[str], None] = print) -> str:
    answers = table2_answers()
    led = Ledger(p.json_out, "recovery-closed-loop", COMMAND, p.model_dump(mode="json"), SCIENCE, planned=len(answers))
    for a in answers:
        lost, seed = a["lost_legs"], a["seed"]
        spec = {"lost_legs": lost, "best_params": a["best_params"], "held_out": p.held_out, "update": p.update}
        log(f"legs {lost} (Table II, seed {seed}): open loop, closed loop and with balance on 1 + 7 + {p.held_out} models")
        led.run(f"legs {'-'.join(map(str, lost))}", spec, seed,
                lambda: walk_both_ways(lost, a["best_params"], seed, p.held_out, p.update), log)
    return render([led.data])


# -- the page ---------------------------------------------------------------------------------

NUMERICS = ("dt_half", "dt_quarter")


@dataclasses.dataclass
class _Counts:
    nominal: bool | None
    numerics: tuple[int, int]
    physical: tuple[int, int]
    held_out: tuple[int, int]

    @property
    def named(self) -> tuple[int, int]:
        return self.numerics[0] + self.physical[0], self.numerics[1] + self.physical[1]


def _count(block: dict) -> _Counts:
    def k(rows):
        return sum(r["target_met"] is True for r in rows), len(rows)

    cases = block["cases"]
    return _Counts(block["nominal"]["target_met"], k([v for n, v in cases.items() if n in NUMERICS]),
                   k([v for n, v in cases.items() if n not in NUMERICS]), k(block["held_out"]))


def _frac(c: tuple[int, int]) -> str:
    return f"{c[0]}/{c[1]}"


def _med(rows: list[dict], key: str, scale: float) -> str:
    return f"{statistics.median(abs(scale * r[key]) for r in rows):.1f}" if rows else "-"


def render(datas: list) -> str:
    data = datas[0]
    if data is None:
        return missing(JSON, COMMAND)
    runs = current_runs(data)
    if not runs:
        return missing(JSON, COMMAND)
    params = data["params"]
    rows, cases_rows, done = [], [], []
    for r in runs:
        res, name = r["result"], r["name"]
        counts = {mode: _count(res[mode]) for mode, _ in DRIVES if mode in res}
        c = counts["closed_loop"]
        n = c.held_out[1]
        lo, hi = wilson(*c.held_out)
        ok = c.named[0] >= DONE_NAMED and c.held_out[0] >= DONE_HELD_OUT * n and n >= 20
        done.append((name, ok))
        for mode, label in DRIVES:
            if mode not in counts:
                continue
            k, block = counts[mode], res[mode]
            allm = [m for m in (block["nominal"], *block["cases"].values(), *block["held_out"]) if not m["fell"]]
            total = 1 + len(block["cases"]) + len(block["held_out"])
            rows.append([_shown(name), label, "yes" if k.nominal else "no", _frac(k.numerics),
                         _frac(k.physical), _frac(k.named), f"{_frac(k.held_out)} ({100 * k.held_out[0] / n:.0f} %)",
                         f"{total - len(allm)}/{total}", _med(allm, "x_f_m", 100), _med(allm, "yaw_f_deg", 1),
                         _med(allm, "y_f_m", 100)])
            if mode == "closed_loop":
                rows[-1][6] += f" [{100 * lo:.0f}, {100 * hi:.0f}]"
        for case in res["closed_loop"]["cases"]:
            a, b = res["open_loop"]["cases"][case], res["closed_loop"]["cases"][case]
            cases_rows.append([_shown(name), case,
                               f"{100 * a['x_f_m']:.1f} / {a['yaw_f_deg']:.1f} / {100 * a['y_f_m']:.1f} "
                               f"{'met' if a['target_met'] else 'not met'}",
                               f"{100 * b['x_f_m']:.1f} / {b['yaw_f_deg']:.1f} / {100 * b['y_f_m']:.1f} "
                               f"{'met' if b['target_met'] else 'not met'}"])
    law = runs[0]["result"]["law"]
    cost = machine_time(data)
    walls = {m: sum(r["result"][m]["wall_s"] for r in runs if m in r["result"]) for m, _ in DRIVES}
    out = [f"The {len(runs)} Table II answers at the default step (docs/table2.json), each walked open loop (the "
           f"paper), closed loop (control.mode closed_loop with the spec's default law: {_law_text(law)}) and closed "
           f"loop with balance (the same law and {_balance_text(runs[0]['result'].get('balance_law'))}) on the "
           f"nominal model, the 7 named cases (2 timestep checks, 5 physical) and {params['held_out']} held-out random "
           "models drawn from the stated ranges (app/jobs/recovery/cases.py RANDOM_RANGES) with the answer's seed "
           "on the held-out stream: the same models every way. Target: the 10 s walk's (forward >= 50 cm, "
           "|lateral| <= 5 cm, |yaw| <= 10 deg, no fall). Medians are over the row's walks that did not fall (nominal, "
           "cases and held-out models); the closed-loop held-out share carries its 95 % Wilson interval.", "",
           md_table(["damage", "drive", "nominal", "timestep checks", "physical cases", "named cases (of 7)",
                     "held-out met", "fell (of all models)", "median abs(x) (cm)", "median abs(yaw) (deg)",
                     "median y (cm)"], rows),
           "Issue 24's bar (closed loop: at least 6 of the 7 named cases and at least 80 % of at least 20 held-out "
           "models): " + "; ".join(f"{_shown(n)} {'met' if ok else '**not met**'}" for n, ok in done) + ".",
           "",
           f"Cost: {cost['runs']} runs, {cost['wall_s']:.0f} s wall in all ({walls['open_loop']:.0f} s of open-loop "
           f"walks, {walls['closed_loop']:.0f} s closed loop: the correction's chunking and set-points; "
           f"{walls['balance']:.0f} s with balance).", "",
           "Per named case, x (cm) / yaw (deg) / y (cm), open loop then closed loop:", "",
           md_table(["damage", "case", "open loop", "closed loop"], cases_rows), "", reading(runs), balance_reading(runs)]
    return "\n".join(out)


def reading(runs: list[dict]) -> str:
    """What the table says about drift, yaw and falls, from the data (issue 45: the prose
    that stood here said the same models fall both ways and the correction changes nothing
    where a walk falls, which a later run contradicted)."""
    n = len(runs)

    def lower(key: str) -> int:
        k = 0
        for r in runs:
            meds = []
            for mode in ("open_loop", "closed_loop"):
                b = r["result"][mode]
                ok = [m for m in (b["nominal"], *b["cases"].values(), *b["held_out"]) if not m["fell"]]
                meds.append(statistics.median(abs(m[key]) for m in ok) if ok else None)
            k += meds[0] is not None and meds[1] is not None and meds[1] < meds[0]
        return k

    falls, misses, changed = [], [], 0
    for r in runs:
        o = [m["fell"] for m in r["result"]["open_loop"]["held_out"]]
        c = [m["fell"] for m in r["result"]["closed_loop"]["held_out"]]
        both = sum(a and b for a, b in zip(o, c))
        only_o, only_c = sum(a and not b for a, b in zip(o, c)), sum(b and not a for a, b in zip(o, c))
        changed += only_o + only_c
        detail = f" ({both} both ways, {only_o} only open loop, {only_c} only closed loop)" if only_o or only_c else ""
        falls.append(f"{_shown(r['name'])} {sum(o)} / {sum(c)}{detail}")
        held = r["result"]["closed_loop"]["held_out"]
        missed = [m for m in held if m["target_met"] is not True]
        if missed:
            fell = sum(m["fell"] for m in missed)
            misses.append(f"{_shown(r['name'])}: misses on {len(missed)} of {len(held)} held-out models closed loop: "
                          f"{fell} fall{'s' if fell != 1 else ''}, {len(missed) - fell} drift, yaw or too short a walk")
    text = (f"**Reading the table** (generated from the same data). The closed-loop median |x| is lower than the "
            f"open-loop one on {lower('x_f_m')} of {n} answers, the median |yaw| on {lower('yaw_f_deg')} of {n}. "
            f"Falls on the held-out models, open / closed loop (the same draws both ways): " + "; ".join(falls) + ". ")
    text += ("The correction changes which held-out models fall for some answers (the counts in brackets)."
             if changed else "The same held-out models fall open and closed loop: the correction does not change "
                             "a fall.")
    if misses:
        text += " Closed loop, " + "; ".join(misses) + "."
    return text + "\n"


def balance_reading(runs: list[dict]) -> str:
    """What balance changes on the held-out models, and what the falls have in common (the
    servo torque limit drawn for each model), from the data."""
    from app.jobs.recovery.cases import RANDOM_RANGES
    from app.jobs.recovery.spec import Control

    parts, weak, gain = [], [], [0, 0]
    for r in runs:
        res = r["result"]
        if "balance" not in res:
            continue
        c, b = res["closed_loop"]["held_out"], res["balance"]["held_out"]
        met = [sum(m["target_met"] is True for m in x) for x in (c, b)]
        fell = [sum(m["fell"] for m in x) for x in (c, b)]
        gain[0] += met[1] - met[0]
        gain[1] += fell[0] - fell[1]
        parts.append(f"{_shown(r['name'])} keeps the target on {met[1]} of {len(b)} ({met[0]} without), falls on "
                     f"{fell[1]} ({fell[0]} without)")
        strength = [d["motor_strength"] for d in res.get("draws", [])]
        falls = [s for s, m in zip(strength, c) if m["fell"]]
        if falls:
            weak_n = sum(1 for s in strength if s <= max(falls))
            lo, hi = RANDOM_RANGES["motor_strength"]
            weak.append(f"{_shown(r['name'])}: its {len(falls)} falls closed loop are all on models drawn with servo "
                        f"torque limits at or below {100 * max(falls):.0f} % (the range is {100 * lo:.0f}-"
                        f"{100 * hi:.0f} %); {weak_n - len(falls)} of the {weak_n} models drawn that weak did not fall")
    if not parts:
        return ""
    text = "**Balance** (generated from the same data). With balance, " + "; ".join(parts) + ". "
    if gain[0] <= 0 and gain[1] <= 0:
        on = Control().balance_gain > 0
        text += ("Over these answers balance keeps the target on no more held-out models and stops no fall: it does "
                 f"not earn its place{', yet it is on by default' if on else ' and stays off by default'} "
                 f"(control.balance_gain {Control().balance_gain:g}). ")
    else:
        text += (f"Over these answers balance keeps the target on {gain[0]:+d} held-out models and changes the falls "
                 f"by {-gain[1]:+d}. ")
    if weak:
        text += "Where the answers fall, the servos were weak: " + "; ".join(weak) + ". "
    return text + "\n"


def _balance_text(law: dict | None) -> str:
    if not law:
        return "no balance"
    return (f"balance gain {law['balance_gain']:g} m/m (integral {law['balance_integral_gain']:g}), tip height offset "
            f"<= {100 * law['balance_limit_m']:g} cm")


def _law_text(law: dict) -> str:
    return (f"update once per {law['update']}, yaw gain {law['yaw_gain']:g} m/rad (integral {law['yaw_integral_gain']:g}),"
            f" lateral gain {law['lateral_gain']:g} m/m (integral {law['lateral_integral_gain']:g}), stride difference "
            f"<= {100 * law['stride_limit_m']:g} cm, sideways stride <= {100 * law['lateral_limit_m']:g} cm, "
            f"odometry {'on' if law['odometry'] else 'off'}")

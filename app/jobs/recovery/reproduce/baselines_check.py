"""Which damages need no recovery at all (`gaitmend reproduce recovery-baselines`): the
nominal tripod on every feasible loss and some partial damages, whether it falls or already
meets the target, kept in docs/recovery_baselines.json, and its section."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.reporting import marked, missing
from app.jobs.recovery.reproduce.rows import feasible_losses
from app.jobs.recovery.metrics import TARGET
from app.jobs.recovery.spec import RecoverySpec
from app.jobs.recovery.reproduce.table2_damages import _name


# -- which damages need no recovery at all --------------------------------------------------------

PARTIAL_DAMAGES = [
    {"locked_joints": [{"leg": 2, "joint": "femur", "angle_deg": 20.0}]},
    {"locked_joints": [{"leg": 3, "joint": "femur", "angle_deg": -20.0}]},
    {"lost_legs": [4], "weak_joints": [{"leg": 3, "joint": "tibia", "torque_scale": 0.3}]},
    {"lost_legs": [1], "weak_joints": [{"leg": 2, "joint": "tibia", "torque_scale": 0.3}]},
]


BASELINES_JSON = "docs/recovery_baselines.json"
BASELINES_COMMAND = "gaitmend reproduce recovery-baselines --write-docs"
BASELINE_KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "tilt_max_deg", "under_3_feet_frac", "fell")


def baselines_data(log: Callable[[str], None] = print) -> dict:
    """The nominal tripod (no recovery) on every feasible 1- and 2-leg loss and a few
    partial damages: does it fall, does it already meet the target? One batch per damage;
    the JSON docs/recovery_baselines.json holds (the page is rendered from it)."""
    from app.jobs.recovery.sequences import nominal_tripod
    from app.jobs.recovery.run import functional_legs, nominal_params, sim_config, sim_model
    from app.robots.catalog import get_robot
    from app.jobs.recovery.evaluate import GaitEvaluator

    t0, c0 = time.monotonic(), time.process_time()
    spec0, rows = RecoverySpec(), []
    for dmg in [{"lost_legs": list(l)} for l in feasible_losses()] + PARTIAL_DAMAGES:
        spec = RecoverySpec(damage=dmg)
        robot = get_robot(spec.robot)
        _, model = sim_model(spec, robot)
        legs = functional_legs(spec)
        ev = GaitEvaluator(robot, model, nominal_tripod(legs), sim_config(spec))
        m = {k: v[0] for k, v in ev.evaluate(nominal_params(robot, legs)).metrics.items()}
        ev.close()
        rows.append({"damage": dmg, "text": _damage_text(dmg), "target_met": bool(TARGET.met(m)),
                     "metrics": {k: (bool(m[k]) if k == "fell" else float(m[k])) for k in BASELINE_KEEP}})
        log(json.dumps(rows[-1]))
    return {"command": BASELINES_COMMAND, "timestep_s": spec0.sim.timestep_s, "duration_s": spec0.sim.duration_s,
            "rows": rows, "wall_s": time.monotonic() - t0, "cpu_s": time.process_time() - c0}


def render_baselines(datas: list) -> str:
    d = datas[0]
    if d is None:
        return missing(BASELINES_JSON, BASELINES_COMMAND)
    out = [f"The nominal tripod with nominal parameters (no recovery) on each damage; timestep "
           f"{1000 * d['timestep_s']:g} ms, {d['duration_s']:g} s walk. 'fell': chassis, coxa or femur touched the "
           "ground. '< 3 feet': share of the walk with fewer than three feet on the ground.", "",
           "| damage | x (cm) | y (cm) | yaw (deg) | max tilt (deg) | < 3 feet | fell | meets the target |",
           "|---|---|---|---|---|---|---|---|"]
    for r in d["rows"]:
        m = r["metrics"]
        out.append(f"| {r['text']} | {100 * m['x_f_m']:.1f} | {100 * m['y_f_m']:.1f} | {m['yaw_f_deg']:.1f} | "
                   f"{m['tilt_max_deg']:.1f} | {100 * m['under_3_feet_frac']:.0f} % | {'**yes**' if m['fell'] else 'no'} | "
                   f"{'**yes**' if r['target_met'] else 'no'} |")
    return "\n".join(out) + "\n"


def _damage_text(d: dict) -> str:
    parts = []
    if d.get("lost_legs"):
        parts.append(_name(tuple(d["lost_legs"])))
    for j in d.get("locked_joints", []):
        parts.append(f"leg {j['leg']} {j['joint']} locked at {j['angle_deg']:g} deg")
    for j in d.get("weak_joints", []):
        parts.append(f"leg {j['leg']} {j['joint']} at {100 * j['torque_scale']:g} % torque")
    return ", ".join(parts)


class BaselinesParams(BaseModel):
    out: Path = Field(Path("docs/recovery_baselines.md"), description="the page to write (its generated section)")
    raw: Path = Field(Path(BASELINES_JSON), description="every damage's walk, the data the page is rendered from")


def _baselines(p: BaselinesParams, log: Callable[[str], None]) -> str:
    data = baselines_data(log=log)
    for path in (p.out, p.raw):
        path.parent.mkdir(parents=True, exist_ok=True)
    p.raw.write_text(json.dumps(data, indent=1) + "\n")
    md = render_baselines([data]).strip("\n") + "\n"
    p.out.write_text(marked("recovery-baselines", BASELINES_COMMAND, md) + "\n")
    return md

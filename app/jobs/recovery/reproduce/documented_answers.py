"""The recovered answers the docs report, and their re-simulation: what the convergence
rule (experiments.py) and the speed measurements (speed.py) re-run."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.jobs.recovery.spec import RecoverySpec


def answers_metrics(answers: list[dict], timestep: float, duration_s: float = 10.0,
                    edit: Callable | None = None, settings: dict | None = None) -> dict[str, np.ndarray]:
    """Re-simulates answers ({"lost_legs", "best_params"}) at ``timestep``; metrics (N,)
    in the answers' order. Answers of one damage run as one batch. ``edit`` changes each
    compiled model first (a physics setting under test); ``settings``: run.sim_model's step
    settings (``pairs``, ``islands``; default: the fast ones)."""
    from app.jobs.recovery.sequences import plan_hexapod
    from app.jobs.recovery.run import sim_config, sim_model
    from app.robots.catalog import get_robot
    from app.jobs.recovery.evaluate import GaitEvaluator

    out: dict[str, np.ndarray] = {}
    groups: dict[tuple, list[int]] = {}
    for i, a in enumerate(answers):
        groups.setdefault(tuple(a["lost_legs"]), []).append(i)
    for lost, idx in groups.items():
        spec = RecoverySpec(damage={"lost_legs": list(lost)}, sim={"timestep_s": timestep, "duration_s": duration_s})
        robot = get_robot(spec.robot)
        _, model = sim_model(spec, robot, **(settings or {}))
        seq = plan_hexapod(lost, robot.nominal_feet_xy(), robot.stance_com_xy(model, spec.gait.stance_height_m))
        if edit is not None:
            edit(model)
        ev = GaitEvaluator(robot, model, seq, sim_config(spec))
        x = np.array([list(answers[i]["best_params"].values()) for i in idx])
        m = ev.evaluate(x).metrics
        ev.close()
        for k, v in m.items():
            out.setdefault(k, np.empty(len(answers), dtype=v.dtype))[idx] = v
    return out


def documented_answers(timestep: float, docs: Path = Path("docs")) -> list[dict]:
    """The recovered gaits the docs report at ``timestep``: Table II rows, the nominal
    answers of the robust comparisons and the answers of that step's convergence searches
    (each written by `gaitmend reproduce ... --write-docs`)."""
    answers = []
    for name, keep in (("table2.json", lambda r: True), ("recovery_robust.json", lambda r: r["mode"] == "nominal"),
                       ("recovery_robust_w20.json", lambda r: r["mode"] == "nominal")):
        if (docs / name).exists():
            answers += [r for r in json.loads((docs / name).read_text())
                        if r.get("timestep_s") == timestep and "best_params" in r and keep(r) and not r["best"]["fell"]]
    conv = docs / "recovery_convergence.json"
    for r in json.loads(conv.read_text()) if conv.exists() else []:
        if r["timestep_s"] == timestep and r.get("set") == "searched":
            answers += [a for a in r["per_answer"] if "best_params" in a]
    return answers

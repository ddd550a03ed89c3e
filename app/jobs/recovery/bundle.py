"""The recovery kind's bundle hook: a job's ``controller/`` files (app/jobs/recovery/export.py
writes them). Apart from export.py because it builds a built-in robot's evaluator again
from the spec (run.py's set-up), while run.py itself writes an uploaded robot's files with
export.py at the end of its job."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.recovery.export import controller_files


def bundle_files(spec, result) -> dict[str, str]:
    """The kind's bundle hook: the ``controller/`` files of a job whose answer's walk was
    recorded with its set-points (jobs before issue 24 have none): a built-in robot's made
    here from the spec, an uploaded robot's as its run made them (``result.files``)."""
    from app.jobs.recovery.evaluate import GaitEvaluator
    from app.jobs.recovery.run import search_bounds, sim_config, sim_model
    from app.jobs.recovery.sequences import plan_hexapod
    from app.robots.catalog import ROBOTS, get_robot

    trace = result.traces.get("best") or {}
    if spec.robot not in ROBOTS:
        return dict(getattr(result, "files", None) or {})
    if "ctrl" not in trace or "best" not in result.summary:
        return {}
    robot = get_robot(spec.robot)
    _, model = sim_model(spec, robot)
    seq = plan_hexapod(spec.damage.lost_legs, robot.nominal_feet_xy(),
                       robot.stance_com_xy(model, spec.gait.stance_height_m))
    cfg = dataclasses.replace(sim_config(spec), nthread=1)  # no simulation here: tips and IK only
    lower, upper = search_bounds(spec, robot)
    ev = GaitEvaluator(robot, model, seq, cfg)
    try:
        x = np.array([list(result.summary["best"]["params"].values())])
        bounds = cfg.law.stride_bounds if cfg.law is not None else (lower[-2], upper[-2])
        return controller_files(ev, x, bounds, cfg.law, {k: np.asarray(v) for k, v in trace.items()})
    finally:
        ev.close()

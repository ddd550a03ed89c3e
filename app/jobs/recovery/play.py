"""A recovery answer walked on a robot that is not the one it was searched on (``Kind.play``):
the same robot under another damage and a perturbed world, as a lab that believed a damage
and searched on it would then run the answer on its real robot (issue 44's arm "the
recovery kind's DE on the believed damage", app/adapt/reproduce/evaluation.py).

The spec is the robot *as it is* (its true damage, the job's walk, step, gait and control
settings); the gaits are answers of a search on the same legs (``bounds.names``: one y0 per
leg left, one x0 per leg left, step length and height), so a believed damage may differ
from the true one in its joint faults, not in its lost legs. The gait sequence, stance and
controller are those a job of this spec builds (run.py ``set_up``, userrobot.py for an
uploaded robot); only the world changes (app/sim/perturb.py ``perturbed_model``)."""

from __future__ import annotations

import numpy as np

from app.jobs.recovery.evaluate import GaitEvaluator
from app.robots.catalog import ROBOTS
from app.sim.perturb import NOMINAL
from app.sim.servos import world_model


def play(spec, gaits, joints: list[str], perturbation=None, stored=None) -> dict[str, list]:
    from app.jobs.recovery import run

    if spec.robot in ROBOTS:
        job = run.set_up(spec)
    else:
        if stored is None:
            raise ValueError(f"robot {spec.robot!r} is an uploaded robot: pass it as `stored`")
        from app.jobs.recovery import userrobot

        job = userrobot.set_up(spec, stored, run._Job, run.scorer)
    try:
        if list(joints) and list(joints) != list(job.names):
            raise ValueError(f"the gaits' parameters {list(joints)} are not this damage's {job.names} "
                             "(a believed damage must lose the same legs as the true one)")
        x = np.atleast_2d(np.asarray(gaits, dtype=float))
        if x.shape[1] != len(job.names):
            raise ValueError(f"gaits have {x.shape[1]} parameters; this damage's search has {len(job.names)}")
        world = world_model(job.mspec, perturbation or NOMINAL, job.model)
        ev = GaitEvaluator(job.robot, world, job.seq, job.ev.cfg)
        try:
            m = {k: v[:, 0] for k, v in ev.evaluate_all(x).metrics.items()}  # (P, 1 variant)
        finally:
            ev.close()
    finally:
        job.close()
    # the walk's frame: y forward (an uploaded robot is turned so that its forward is +y), x to the right
    return {"forward_m": [float(v) for v in m["y_f_m"]], "lateral_m": [float(-v) for v in m["x_f_m"]],
            "yaw_deg": [float(v) for v in m["yaw_f_deg"]], "fell": [bool(v) for v in m["fell"]],
            "duration_s": [float(spec.sim.duration_s)] * x.shape[0]}

"""app/sim/servos.py: the servos' strength and gains as fields of a perturbation, scaled as the
held-out random models scale them (app/sim/perturb.py ``random_model``, which keeps its own
three lines until its reproductions can be re-run)."""

from __future__ import annotations

import numpy as np

from app.jobs.recovery import run
from app.jobs.registry import parse_spec
from app.sim import perturb
from app.sim.servos import ServoPerturbation, world_model


def test_servo_fields_scale_the_model_as_the_held_out_random_models_do():
    job = run.set_up(parse_spec({"kind": "recovery"}))
    try:
        draw = {k: (lo + hi) / 2 for k, (lo, hi) in perturb.RANDOM_RANGES.items()} | {"floor_seed": 1,
                                                                                      "motor_strength": 0.8,
                                                                                      "servo_gain_scale": 1.2}
        mass = job.robot.geometry.total_mass
        drawn = perturb.random_models(job.mspec, [draw], mass)[0]
        ours = world_model(job.mspec, ServoPerturbation(
            "r", "r", friction_scale=draw["friction_scale"], mass_scale=draw["mass_scale"],
            payload_kg=draw["payload_share"] * mass, payload_offset_m=(draw["payload_x_m"], draw["payload_y_m"], 0.0),
            motor_strength=0.8, servo_gain_scale=1.2), job.model)
        for field in ("actuator_forcerange", "actuator_biasprm", "actuator_gainprm"):
            assert np.array_equal(getattr(ours, field), getattr(drawn, field)), field
            assert not np.array_equal(getattr(ours, field), getattr(job.model, field)), field
        # at 1.0 nothing moves: the plain perturbation's model, bit for bit
        same = world_model(job.mspec, ServoPerturbation("n", "n", friction_scale=0.9), job.model)
        plain = perturb.perturbed_model(job.mspec, perturb.Perturbation("n", "n", friction_scale=0.9), job.model)
        for field in ("actuator_forcerange", "actuator_biasprm", "actuator_gainprm", "geom_friction"):
            assert np.array_equal(getattr(same, field), getattr(plain, field)), field
        assert np.array_equal(job.model.actuator_forcerange, world_model(job.mspec, perturb.NOMINAL,
                                                                         job.model).actuator_forcerange)
    finally:
        job.close()

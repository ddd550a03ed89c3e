"""Servo strength and gains as fields of a world's perturbation: every servo's torque limit
(``motor_strength``) and its gains, kp, kd and ki together (``servo_gain_scale``). The
held-out random models draw the same two (app/sim/perturb.py ``RANDOM_RANGES``,
``random_model``); here they are fields of a ``Perturbation``, so that a kind's ``play`` (the
adaptation's simulated reality, app/adapt/reality.py) applies them with the rest of the world
through ``world_model``. Every servo of the project's models is MuJoCo's pid-type actuator
(gainprm[0] ki, biasprm[1:3] -kp, -kd), built-in or uploaded (app/robots/upload adds them).

Left for later: perturb.random_model scales its draws with the same three lines; it is a
science file of committed reproductions (app/jobs/repertoire/reproduce/experiments.py
SCIENCE), and moving its lines here would stale them. tests/sim/test_servos.py holds the two
to the same models."""

from __future__ import annotations

import dataclasses

import mujoco

from app.sim.perturb import Perturbation, perturbed_model


@dataclasses.dataclass(frozen=True)
class ServoPerturbation(Perturbation):
    motor_strength: float = 1.0  # every servo's torque limit, x
    servo_gain_scale: float = 1.0  # every servo's kp, kd and ki, x


def scale_servos(m: mujoco.MjModel, motor_strength: float, servo_gain_scale: float) -> mujoco.MjModel:
    """``m`` (a model of its own, e.g. ``perturbed_model``'s copy) with its servos scaled, in place."""
    m.actuator_forcerange[:] *= motor_strength
    m.actuator_biasprm[:, 1:3] *= servo_gain_scale  # -kp, -kd
    m.actuator_gainprm[:, 0] *= servo_gain_scale  # ki
    return m


def world_model(spec: mujoco.MjSpec, p: Perturbation, model: mujoco.MjModel | None = None) -> mujoco.MjModel:
    """``perturbed_model`` and, for a ``ServoPerturbation``, its servos scaled."""
    m = perturbed_model(spec, p, model)
    if isinstance(p, ServoPerturbation) and (p.motor_strength != 1.0 or p.servo_gain_scale != 1.0):
        scale_servos(m, p.motor_strength, p.servo_gain_scale)
    return m

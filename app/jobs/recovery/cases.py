"""The recovery kind's robustness cases: the standard evidence cases (``evidence.CASES``)
as perturbed MuJoCo worlds of the hexapod. The kind picks seven of them and says in its
labels what they cover on this robot; the payload and the rough floor are built here
from the robot (their amounts are the kind's, not the protocol's). Beside the named cases,
random models drawn from stated ranges (``RANDOM_RANGES``): the held-out set every job is
judged on, and the models a randomised search scores on."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import mujoco
import numpy as np

from app.jobs import evidence
from app.sim.perturb import Perturbation, edit_model, perturbed_model

CASE_NAMES = ("dt_half", "dt_quarter", "friction_0.7", "friction_1.3", "mass_+10pct", "payload", "rough_terrain")

PAYLOAD_SHARE = 0.1  # of the robot's mass
# 2 cm to one side of the torso's centre of mass, so that the payload also tests lateral balance
PAYLOAD_OFFSET_M = (0.02, 0.0, 0.0)
FLOOR_AMPLITUDE_M = 0.005


def payload_kg(robot_mass_kg: float) -> float:
    return round(PAYLOAD_SHARE * robot_mass_kg, 3)


def _label(name: str, robot_mass_kg: float) -> str | None:
    """The kind's own label of a case (None: the standard one)."""
    return {"mass_+10pct": "all link and body masses +10 %",
            "payload": f"payload {payload_kg(robot_mass_kg)} kg, 2 cm right of the torso's centre of mass",
            "rough_terrain": "rough floor: height field, heights uniform in +-5 mm on a 4 cm grid"}.get(name)


def perturbation(name: str, robot_mass_kg: float) -> Perturbation:
    """The case ``name`` of ``CASE_NAMES`` on a robot of that mass."""
    if name not in CASE_NAMES:
        raise KeyError(f"unknown recovery robustness case {name!r}; known: {list(CASE_NAMES)}")
    c = evidence.case(name, _label(name, robot_mass_kg))
    p = Perturbation(c.name, c.label, timestep_scale=c.timestep_scale, friction_scale=c.friction_scale,
                     mass_scale=c.mass_scale)
    if name == "payload":
        p = dataclasses.replace(p, payload_kg=payload_kg(robot_mass_kg), payload_offset_m=PAYLOAD_OFFSET_M)
    elif name == "rough_terrain":
        p = dataclasses.replace(p, terrain_amplitude_m=FLOOR_AMPLITUDE_M)
    return p


def walking_cases(robot_mass_kg: float, names: Sequence[str] = CASE_NAMES) -> list[Perturbation]:
    """The named cases (default: all seven) in the order asked."""
    return [perturbation(n, robot_mass_kg) for n in names]


# -- random models: the held-out set (and the randomised search) ---------------------------------

# The stated ranges every random model is drawn from, uniformly and independently. Friction:
# every geom's sliding friction; mass: every body's mass and inertia; payload: a share of the
# robot's mass on the torso, its centre offset in x and y; motor strength: every servo's torque
# limit; servo gains: every servo's kp, kd and ki together; floor: a height field of heights
# uniform in +-amplitude on a 4 cm grid. Not modelled: actuation latency, backlash, sensor noise.
RANDOM_RANGES = {
    "friction_scale": (0.6, 1.4),
    "mass_scale": (0.9, 1.1),
    "payload_share": (0.0, 0.15),
    "payload_x_m": (-0.03, 0.03),
    "payload_y_m": (-0.03, 0.03),
    "motor_strength": (0.7, 1.0),
    "servo_gain_scale": (0.7, 1.3),
    "floor_amplitude_m": (0.0, 0.005),
}
RANGE_TEXT = ("friction x 0.6-1.4, every mass x 0.9-1.1, payload 0-15 % of the robot's mass within 3 cm of the "
              "torso's centre in x and y, servo torque limits x 0.7-1.0, servo gains (kp, kd, ki) x 0.7-1.3, rough "
              "floor +-0-5 mm on a 4 cm grid")
# Streams of the job's seed no search draws from (the search uses the seed itself, the
# random-search control seed + 7919): the held-out set, and the randomised search's draws.
HELD_OUT_STREAM = 0x48454C44  # "HELD"
SEARCH_STREAM = 0x52414E44  # "RAND"
FLOOR_CELL_M = 0.04


def draw_models(seed: int, n: int, stream: int = HELD_OUT_STREAM, generation: int = 0) -> list[dict[str, float]]:
    """``n`` random models (each a dict of RANDOM_RANGES' draws plus a floor seed), the same
    for the same (seed, stream, generation)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(stream), int(generation)]))
    out = []
    for _ in range(n):
        d = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in RANDOM_RANGES.items()}
        out.append(d | {"floor_seed": int(rng.integers(2**31))})
    return out


def random_world(mspec: mujoco.MjSpec) -> mujoco.MjModel:
    """The damaged robot on a height-field floor: the compiled structure every random model
    shares (one size signature, so a whole set runs in one rollout call)."""
    return perturbed_model(mspec, Perturbation("rough", "rough floor", terrain_amplitude_m=RANDOM_RANGES[
        "floor_amplitude_m"][1], terrain_cell_m=FLOOR_CELL_M))


def random_model(world: mujoco.MjModel, d: dict[str, float], robot_mass_kg: float) -> mujoco.MjModel:
    """One random model (a draw of ``draw_models``) of ``random_world``'s structure."""
    p = Perturbation("random", "random model", friction_scale=d["friction_scale"], mass_scale=d["mass_scale"],
                     payload_kg=d["payload_share"] * robot_mass_kg, payload_offset_m=(d["payload_x_m"],
                                                                                      d["payload_y_m"], 0.0))
    m = edit_model(world, p)
    m.actuator_forcerange[:] *= d["motor_strength"]
    m.actuator_biasprm[:, 1:3] *= d["servo_gain_scale"]  # -kp, -kd of MuJoCo's pid actuator
    m.actuator_gainprm[:, 0] *= d["servo_gain_scale"]  # ki
    a = d["floor_amplitude_m"]
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    hf = m.geom_dataid[floor]
    rows = slice(m.hfield_adr[hf], m.hfield_adr[hf] + m.hfield_nrow[hf] * m.hfield_ncol[hf])
    m.hfield_data[rows] = np.random.default_rng(d["floor_seed"]).random(rows.stop - rows.start)
    m.hfield_size[hf, 2] = max(2 * a, 1e-9)  # heights span [z - a, z + a] around the plane's height
    m.geom_pos[floor, 2] = world.geom_pos[floor, 2] + RANDOM_RANGES["floor_amplitude_m"][1] - a
    return m


def random_models(mspec: mujoco.MjSpec, draws: Sequence[dict[str, float]], robot_mass_kg: float) -> list[mujoco.MjModel]:
    world = random_world(mspec)
    return [random_model(world, d, robot_mass_kg) for d in draws]

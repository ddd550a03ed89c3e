"""The recovery kind's robustness cases: the standard evidence cases (``evidence.CASES``)
as perturbed MuJoCo worlds of the hexapod. The kind picks seven of them and says in its
labels what they cover on this robot; the payload and the rough floor are built here
from the robot (their amounts are the kind's, not the protocol's). Beside the named cases,
random models drawn from stated ranges (``RANDOM_RANGES``, the shared layer's vocabulary in
app/sim/perturb.py): the held-out set every job is judged on, and the models a randomised
search scores on."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from app.jobs import evidence
from app.sim import perturb
from app.sim.perturb import FLOOR_CELL_M, Perturbation

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
            "rough_terrain": "rough floor: height field, heights uniform in +-5 mm on a 50 cm grid"}.get(name)


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
        p = dataclasses.replace(p, terrain_amplitude_m=FLOOR_AMPLITUDE_M, terrain_cell_m=FLOOR_CELL_M)
    return p


def walking_cases(robot_mass_kg: float, names: Sequence[str] = CASE_NAMES) -> list[Perturbation]:
    """The named cases (default: all seven) in the order asked."""
    return [perturbation(n, robot_mass_kg) for n in names]


# -- random models: the held-out set (and the randomised search) ---------------------------------
# The shared vocabulary (app/sim/perturb.py): the stated ranges, the seeded draws and the
# streams of the job's seed; named here for the recovery modules and reproductions that read them.
RANDOM_RANGES, RANGE_TEXT = perturb.RANDOM_RANGES, perturb.RANGE_TEXT
HELD_OUT_STREAM, SEARCH_STREAM = perturb.HELD_OUT_STREAM, perturb.SEARCH_STREAM
CHOICE_STREAM = 0x43484F53  # "CHOS": the robust choice's models (spec.Choice), drawn from the same ranges
draw_models, random_world, random_model, random_models = (perturb.draw_models, perturb.random_world,
                                                          perturb.random_model, perturb.random_models)

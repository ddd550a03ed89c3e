"""What every freegait reproduction shares: the science files its ledgers' code version
covers, its JSON files under docs/ and commands, the world it walks in (terrain and
minefield), the ledger it appends to, and the number format and ledger reading its
renderers use."""

from __future__ import annotations

import math

from app.jobs.freegait.planner.walk import stand_pose
from app.jobs.ledger import Ledger, results_by_name
from app.robots.silo6 import SILO6
from app.jobs.freegait.terrain import make_minefield, make_terrain


KEVS = (0.0, 0.02, 0.04, 0.06, 0.08, 0.1)
SCIENCE = ("app/jobs/freegait/planner", "app/jobs/freegait/terrain.py", "app/robots/silo6/__init__.py")
KEV_JSON, ZONES_JSON, CRAB_JSON = "docs/freegait_kev.json", "docs/freegait_zones.json", "docs/freegait_crab.json"
CIRCLING_JSON, SPINNING_JSON = "docs/freegait_circling.json", "docs/freegait_spinning.json"
SWEEP_JSON, NOISE_JSON = "docs/freegait_sweep.json", "docs/freegait_noise.json"


def _cmd(name: str) -> str:
    return f"gaitmend reproduce freegait{'-' + name if name != 'kev' else ''} --write-docs"


def _world(length: float, width: float, roughness: float, t_seed: int, density: float, f_seed: int):
    ter = make_terrain((-1.0, length - 1.0), (-width / 2, width / 2), roughness, t_seed)
    _, feet = stand_pose(SILO6, ter)
    return ter, make_minefield(ter, density, 0.05, 0.15, f_seed, cleared=feet[:, :2])


def _ledger(p, name: str, planned: int) -> Ledger:
    return Ledger(p.json_out, f"freegait-{name}", _cmd(name), p.model_dump(mode="json"), SCIENCE, planned=planned)


def _f(v, fmt="{:.3f}"):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v)


def _first(datas: list) -> tuple[dict | None, dict]:
    """(the ledger data or None, its current results by run name)."""
    data = datas[0]
    return data, (results_by_name(data) if data else {})

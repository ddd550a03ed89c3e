"""A map's gaits played on a robot that is not the map's: the same robot under another
damage (a leg lost, a joint locked) and a perturbed world, as the adaptation's simulated
reality needs them (``Kind.play``, app/adapt/reality.py). The evaluator and the controller
are the map's own (evaluate.py, controller.py); only the servos change: the damaged robot's
servos take their joint's three parameters from the gait, by joint name, and a servo the
damage removed has nothing to drive (ITE's robot sends its lost leg commands that move
nothing)."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.repertoire.body import build
from app.jobs.repertoire.controller import PARAMS_PER_JOINT, Layout
from app.jobs.repertoire.evaluate import Evaluator
from app.sim.perturb import NOMINAL
from app.sim.servos import world_model


def on_servos(gaits: np.ndarray, joints: list[str], servos: list[str]) -> np.ndarray:
    """Gaits over ``joints`` (P, 3 len(joints) + 1) as gaits over ``servos`` (a subset of
    ``joints``, any order): each servo's three parameters and the shared period."""
    x = np.atleast_2d(np.asarray(gaits, dtype=float))
    if x.shape[1] != PARAMS_PER_JOINT * len(joints) + 1:
        raise ValueError(f"gaits have {x.shape[1]} parameters; {len(joints)} joints need "
                         f"{PARAMS_PER_JOINT * len(joints) + 1}")
    missing = [s for s in servos if s not in joints]
    if missing:
        raise ValueError(f"the robot's servos {missing} are not among the map's joints")
    cols = [PARAMS_PER_JOINT * joints.index(s) + k for s in servos for k in range(PARAMS_PER_JOINT)]
    return np.concatenate([x[:, cols], x[:, -1:]], axis=1)


def play(spec, gaits, joints: list[str], perturbation=None, stored=None) -> dict[str, list]:
    body = build(spec, stored)
    p = perturbation or NOMINAL
    world = dataclasses.replace(body, model=world_model(body.mspec, p, body.model))
    c = spec.controller
    layout = Layout(body.lo, body.hi, body.stance, c.amplitude, c.offset, c.period_s, c.ramp_s, body.joints)
    ev = Evaluator(world, layout, spec.sim.duration_s, spec.sim.settle_s)
    try:
        m = ev.evaluate(on_servos(gaits, list(joints), body.joints))
    finally:
        ev.close()
    n = len(m["forward_m"])
    return {"forward_m": m["forward_m"].tolist(), "lateral_m": m["lateral_m"].tolist(),
            "yaw_deg": m["yaw_deg"].tolist(), "fell": [bool(f) for f in m["fell"]],
            "duration_s": [ev.n_walk * ev.dt] * n}


# -- elites to replay on the job page ------------------------------------------------------------

REPLAYS = 12  # elites recorded for the replay: all of a map this small, else the best half and a spread half
REPLAY_HZ = 50.0  # a replay trace keeps the state at this rate (the replay plays at 25 frames a second)
ELITE = "elite_"  # trace names: elite_<cell>


def elite_name(cell: int) -> str:
    return f"{ELITE}{int(cell)}"


def replay_cells(cells, objective, measures, bounds, k: int = REPLAYS) -> list[int]:
    """The cells whose elites get a replay: every one when there are at most ``k``; else the
    ``k // 2`` furthest-walking and, of the rest, ``k - k // 2`` spread over the map (each the
    elite whose descriptor is furthest, in the bounds' units, from those already picked),
    in the order picked. Ties go to the lower cell."""
    cells = np.asarray(cells, dtype=int)
    n = len(cells)
    if n <= k:
        return [int(c) for c in cells[np.lexsort((cells, -np.asarray(objective, dtype=float)))]]
    obj = np.asarray(objective, dtype=float)
    lo, hi = np.asarray(bounds, dtype=float).T
    m = (np.asarray(measures, dtype=float).reshape(n, -1) - lo) / np.where(hi > lo, hi - lo, 1.0)
    order = np.lexsort((cells, -obj))
    picked = list(order[:k // 2])
    dist = np.min(np.linalg.norm(m[:, None, :] - m[picked][None, :, :], axis=-1), axis=1)
    while len(picked) < k:
        cand = np.lexsort((cells, -dist))[0]
        picked.append(int(cand))
        dist = np.minimum(dist, np.linalg.norm(m - m[cand], axis=-1))
    return [int(cells[i]) for i in picked]


def elite_traces(ev, elites: dict, bounds, k: int = REPLAYS) -> dict[str, dict[str, np.ndarray]]:
    """{elite_<cell>: its walk as the evaluator records it, kept at REPLAY_HZ} for the
    ``replay_cells`` of the map ``elites`` (archive.table's columns): what the job page
    replays when an elite is picked."""
    if not elites["cell"]:
        return {}
    cells = replay_cells(elites["cell"], elites["objective"], elites["measures"], bounds, k)
    row = {c: i for i, c in enumerate(elites["cell"])}
    every = max(1, int(round(1.0 / (REPLAY_HZ * ev.dt))))
    out = {}
    for c in cells:
        tr = ev.record(np.asarray(elites["solution"][row[c]], dtype=float))
        out[elite_name(c)] = {name: np.asarray(v)[::every] for name, v in tr.items()}
    return out

"""What ``gaitmend bench`` measures for freegait: the foothold search over all N^3 tripods
and a walk against real time."""

from __future__ import annotations

import time

import numpy as np

from app.jobs.base import BenchEntry
from app.jobs.freegait.planner.geometry import Motion, kinematic_margin
from app.jobs.freegait.planner.params import GaitParams, nominal_re, r1
from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.search import SearchInput, candidate_grid, search
from app.jobs.freegait.planner.walk import WalkConfig, walk
from app.robots.silo6 import SILO6, TRIPODS
from app.jobs.freegait.terrain import Minefield
from app.jobs.freegait.reproduce.walks import _world


# -- bench ------------------------------------------------------------------------------------

def search_case(n: int):
    p = GaitParams(n_candidates=n)
    m = Motion(0.02, 0.0)
    legs = [l - 1 for l in TRIPODS[1]]
    sup = [l - 1 for l in TRIPODS[0]]
    rects = SILO6.workspaces()[legs]
    cand = np.stack([candidate_grid(r, m.direction, n, p) for r in rects])
    nom = SILO6.nominal_feet()[:, :2]
    ks = float(kinematic_margin(nom[sup] - [0.03, 0], SILO6.workspaces()[sup], m, r1(m, p)).min())
    zones_w = Minefield(np.random.default_rng(0).uniform([-0.6, -0.8], [0.8, 0.8], (12, 2)), 0.025, 0.075)
    allowed = lambda q: zones_w.distance(q) >= zones_w.safe_radius  # noqa: E731
    return SearchInput(m, p, cand, nom[legs] - [0.06, 0], rects, ks, nominal_re(m, p, SILO6.stroke), allowed)


def _bench(quick: bool, log) -> dict:
    out = {}
    for n in (10, 15, 20):
        inp = search_case(n)
        search(inp)
        reps = 20 if quick else 100
        ts = []
        for _ in range(reps):
            t = time.perf_counter()
            search(inp)
            ts.append(time.perf_counter() - t)
        out[f"foothold_search_N{n}_ms"] = round(1e3 * float(np.median(ts)), 3)
        out[f"foothold_search_N{n}_best_ms"] = round(1e3 * float(np.min(ts)), 3)  # least disturbed by other load
        log(f"N={n} ({n ** 3} tripods): {out[f'foothold_search_N{n}_ms']} ms median, "
            f"{out[f'foothold_search_N{n}_best_ms']} ms best of {reps}")
    out["foothold_search_target_ms"] = 5.0
    dist = 0.5 if quick else 2.0
    ter, fld = _world(dist + 2.5, 3.0, 0.04, 0, 3.0, 0)
    r = walk(ter, fld, WalkConfig(route=Route(distance=dist)))
    out["walk_m"] = dist
    out["walk_sim_s"] = round(float(r.steps["t"][-1]), 2)
    out["walk_wall_s"] = round(r.wall_s, 2)
    out["walk_realtime_factor"] = round(float(r.steps["t"][-1]) / r.wall_s, 2)
    log(f"{dist} m walk: {out['walk_sim_s']} s simulated in {out['walk_wall_s']} s")
    return out


BENCH = [BenchEntry("freegait", "foothold search (all N^3 tripods, six conditions, Ev) for N = 10, 15, 20; "
                                "a walk at the default zone density against real time", _bench)]

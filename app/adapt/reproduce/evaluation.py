"""`gaitmend reproduce adapt`: ITE as published against gaitmend's multi-prior method on random
simulated realities (issue 44, "Done when"), appended reality by reality to
docs/adapt_evaluation.json; docs/adapt.md's "Evaluation" is rendered from it (``report``).

**Maps.** Built with the repertoire kind (``Kind.run``) at ``MAP_BUDGET`` (stated in the JSON
and on the page), cached under ``--maps-dir`` (each is rebuilt the same from its spec and
seed; the JSON keeps every map's spec and a digest of its elites, and a continued run whose
maps differ is refused): ITE's map of the intact robot over the contact-share descriptor,
and maps built for stated damages (``PRIOR_DAMAGES``), lifted into the intact map's space
(app/adapt/maps.py ``in_space_of``: a lost leg's contact share is 0; a joint a damaged map
does not drive holds its stance).

**Realities.** Reality k (seed ``(seed, k)``) is of damage type k mod 3: one lost leg, one
or two locked joints at a random angle, or one lost leg and one locked joint, drawn from
legs and joints such that no reality is a map's damage; and a held-out perturbation of the
world: friction, masses and inertias, a payload off the trunk's centre, half of them a
rough floor (app/adapt/reality.py ``World``). The methods never see it.

**Oracle and trials.** Every elite of every map is played on the reality in one batched
call of the repertoire's evaluator per map (app/adapt/reality.py ``play_many``): the best
forward speed of a gait that does not fall is the oracle, and the arms' trials are read
from that table (a gait measures the same alone or in a batch: the rollouts of a batch are
independent and deterministic, tests/adapt/test_evaluation.py checks it against ``play``).

**Arms.** ``ite``: ITE as published on its one map (app/adapt/methods.py ``ITE``);
``gaitmend``: ``GAITMEND`` over all the maps; ablations, each one part of ``GAITMEND``
switched off; ``random``: 20 elites of ITE's map drawn uniformly without replacement.
Each arm runs until its own stop rule or 20 trials. ``de_believed``: the recovery kind's DE
(``DE_SPEC``) searched in simulation on the damage the lab believes (``believed_damage``: the
true one with its last joint fault left out), its answer played once on the reality through
the recovery kind's ``Kind.play``; it runs after a reality's other arms (``run_de_believed``)
and is kept when the other arms are re-run.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from app.adapt import methods as M
from app.adapt.maps import Repertoire, in_space_of, read_repertoire
from app.adapt.reality import Measured, Reality, play_many, pooled, rescore, scenario_priors
from app.adapt.recovered import recovered, target_speed
from app.adapt.reproduce.de_arm import DE_ARM, de_pass, de_setup
from app.adapt.reproduce.params import ANT_COMMAND, COMMAND, JSON, Params
from app.adapt.simulate import run as run_loop
from app.core.host import machine
from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.ledger import ROOT, write_json_atomic
from app.jobs.registry import get_kind, parse_spec

SCHEMA = 1
ROBOT = "jethexa"
MAX_TRIALS = 20

# the maps' budget: MAP-Elites iterations x batch, the archive's cells, the trial
MAP_BUDGET = {"archive": {"cells": 400},
              "search": {"iterations": 30, "batch_size": 64, "checkpoint_every": 30},
              "sim": {"duration_s": 3.0, "settle_s": 0.5, "timestep_s": 0.004},
              "evidence": {"rescore_elites": 0, "random_control": False}}
QUICK_BUDGET = {"archive": {"cells": 24},
                "search": {"iterations": 3, "batch_size": 8, "checkpoint_every": 3},
                "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
                "evidence": {"rescore_elites": 0, "random_control": False}}
PRIOR_DAMAGES = {  # the maps' damages besides the intact robot's: no reality is one of these
    "lost leg1": {"lost_legs": ["leg1"]},
    "lost leg6": {"lost_legs": ["leg6"]},
    "locked leg3.leg3_femur": {"locked_joints": [{"leg": "leg3", "joint": "leg3_femur", "angle_deg": 20.0}]},
}
REALITY_LOST = ("leg2", "leg3", "leg4", "leg5")  # legs a reality may lose (the maps lost leg1 and leg6)
JOINTS = ("coxa", "femur", "tibia")
TYPES = ("lost_leg", "locked_joints", "lost_leg_and_locked_joint")

# the uploaded robot: the Gymnasium ant, prepared as an upload is (app/robots/upload/samples.py)
ANT = "gym_ant"
ANT_PRIOR_DAMAGES = {
    "lost front_left_leg": {"lost_legs": ["front_left_leg"]},
    "locked back_leg.ankle_3": {"locked_joints": [{"leg": "back_leg", "joint": "ankle_3", "angle_deg": 20.0}]},
}
ANT_REALITY_LOST = ("front_right_leg", "back_leg", "right_back_leg")  # the maps lost front_left_leg
ANT_TYPES = ("lost_leg", "locked_joint", "weak_joint", "passive_joint", "shortened_leg")


@dataclasses.dataclass(frozen=True)
class Profile:
    """A robot the evaluation runs on: its name on the page, the spec's robot (a built-in's
    name or the uploaded robot's id) and the uploaded robot itself (None for a built-in),
    the maps' stated damages, the legs a reality may lose, its damage types and which of
    its realities' results were seen while arms were designed."""

    name: str
    robot: str
    stored: Any
    prior_damages: dict
    reality_lost: tuple[str, ...]
    types: tuple[str, ...]
    design_seen: int | None

    def robots(self, robot_id: str) -> Any:
        """The loader a Reality and a run context take: the one uploaded robot."""
        if self.stored is None or robot_id != self.robot:
            raise SpecError([{"field": "robot", "message": f"no uploaded robot {robot_id!r} in this evaluation"}])
        return self.stored


@functools.lru_cache(maxsize=None)  # the ant is prepared as an upload once, not in every step that asks
def profile_of(name: str) -> Profile:
    if name == ROBOT:
        return Profile(ROBOT, ROBOT, None, PRIOR_DAMAGES, REALITY_LOST, TYPES, DESIGN_SEEN)
    if name == ANT:
        from app.robots.upload.samples import sample_robot

        robot_id, stored = sample_robot(ANT)
        return Profile(ANT, robot_id, stored, ANT_PRIOR_DAMAGES, ANT_REALITY_LOST, ANT_TYPES, None)
    raise ValueError(f"no evaluation profile for robot {name!r}")

_G = M.GAITMEND
# name: (words, settings, the maps it holds, the target stated); maps: "ite" (ITE's map), "all" (every map),
# "scenarios" (every map's elites pooled, one prior per stated damage and their mean), "expected" (that mean alone)
ARMS: dict[str, tuple[str, M.Settings, str, bool]] = {
    "ite": ("ITE as published: one map (intact), UCB kappa 0.05, stop at 0.9 x the best prediction", M.ITE,
            "ite", False),
    "gaitmend": ("gaitmend: every map a prior by likelihood, straight, falls as 0, no repeat, stop at the target",
                 _G, "all", True),
    "gaitmend_scenarios": ("gaitmend over the pooled elites, one prior per stated damage (each elite re-simulated on "
                           "it before any damage) and their mean, by likelihood", _G, "scenarios", True),
    "expected": ("gaitmend, one prior: each pooled elite's mean over the stated damages", _G, "expected", True),
    "gaitmend_worlds": ("gaitmend_scenarios with each stated damage also in a training world (not a reality's)",
                        _G, "worlds", True),
    "gaitmend_worlds_2": ("gaitmend_worlds with another draw of the training worlds", _G, "worlds_2", True),
    "expected_worlds": ("gaitmend, one prior: each pooled elite's mean over the stated damages and training worlds",
                        _G, "expected_worlds", True),
    "ite_target": ("ITE with gaitmend's stop at the target", M.ITE, "ite", True),
    "no_priors": ("gaitmend without priors (ITE's map alone)", dataclasses.replace(_G, priors=False), "ite", True),
    "no_straight": ("gaitmend without straight", dataclasses.replace(_G, straight=False), "all", True),
    "no_falls": ("gaitmend without falls", dataclasses.replace(_G, falls=False), "all", True),
    "no_repeat_off": ("gaitmend, repeats allowed", dataclasses.replace(_G, no_repeat=False), "all", True),
    "no_target": ("gaitmend with the 0.9 rule (guarded) instead of the target", _G, "all", False),
    "no_target_no_guard": ("gaitmend with the 0.9 rule as published", dataclasses.replace(_G, walks_to_stop=False),
                           "all", False),
}
RANDOM = "random"

# -- maps -------------------------------------------------------------------------------------------

def map_specs(quick: bool = False, profile: Profile | None = None) -> dict[str, dict]:
    """name -> the repertoire spec of each map (ITE's first)."""
    profile = profile or profile_of(ROBOT)
    budget = QUICK_BUDGET if quick else MAP_BUDGET
    base = {"kind": "repertoire", "robot": profile.robot, "seed": 0} | budget
    out = {"intact": base | {"descriptor": {"type": "contact_share"}}}
    for k, (name, damage) in enumerate(profile.prior_damages.items()):
        out[name] = base | {"seed": k + 1, "damage": damage, "descriptor": {"type": "contact_share"}}
    return out


def _digest(rep: Repertoire) -> str:
    h = hashlib.sha256()
    for a in (rep.params, rep.map.descriptors, rep.map.forward_m):
        h.update(np.ascontiguousarray(np.round(a, 9)).tobytes())
    return h.hexdigest()[:16]


def build_maps(p: Params, log: Callable[[str], None]) -> tuple[list[Repertoire], list[dict]]:
    """The maps in ITE's map's space (ITE's first), and what the JSON says of each."""
    kind = get_kind("repertoire")
    profile = profile_of(p.robot)
    p.maps_dir.mkdir(parents=True, exist_ok=True)
    reps, info = [], []
    for name, spec in map_specs(p.quick, profile).items():
        key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
        path = p.maps_dir / f"{name.replace(' ', '_').replace('.', '_')}-{key}.json"
        if not path.exists():
            log(f"building map {name} ({spec['search']['iterations']} x {spec['search']['batch_size']} gaits) ...")
            t0 = time.perf_counter()
            path.write_text(dumps(kind.run(parse_spec(spec), MemoryContext(robots=profile.robots)).summary))
            log(f"map {name}: {time.perf_counter() - t0:.0f} s")
        rep = read_repertoire(path, name)
        reps.append(rep)
        s = json.loads(path.read_text())
        info.append({"name": name, "spec": spec, "elites": len(rep.map.forward_m),
                     "coverage": s["archive"]["coverage"], "best_forward_m": s["archive"]["best_forward_m"],
                     "descriptor": rep.descriptor, "joints": len(rep.joints), "digest": _digest(rep)})
    reps = [reps[0]] + [in_space_of(r, reps[0]) for r in reps[1:]]
    return reps, info


SCENARIO_MEAN = "mean over stated damages"


TRAIN_STREAM = 1_000_003  # the training worlds' seeds (seed, TRAIN_STREAM, i): never a reality's (seed, k)


def scenario_maps(p: Params, reps: list[Repertoire], log: Callable[[str], None],
                  worlds: bool = False, draw: int = 0) -> list[Repertoire]:
    """Every map's elites pooled (in the maps' order) and re-simulated, before any damage, on
    the robot intact and under each map's damage (nominal world): one prior per stated damage,
    each the pooled elites' performance there (a fall counts 0), and first their mean, the
    performance a gait can expect of a damage among those (gaitmend_scenarios, expected).
    ``worlds``: besides, each stated damage in one training world drawn as a reality's world
    is (``draw_world``) from its own stream (``TRAIN_STREAM`` + ``draw``), none a reality's
    (gaitmend_worlds, expected_worlds; ``draw`` 1: another set of training worlds,
    gaitmend_worlds_2, to see how much the result owes to the draw)."""
    profile = profile_of(p.robot)
    pool = pooled(reps)
    damages = {"intact": {}} | profile.prior_damages
    key = hashlib.sha256("".join(_digest(r) for r in reps).encode()).hexdigest()[:12]

    def tables_of(cache: Path, realities: dict[str, dict]) -> dict:
        if cache.exists():
            return _table_read(json.loads(cache.read_text()))
        log(f"re-simulating the {len(pool.map.forward_m)} pooled elites on {len(realities)} stated damages ...")
        out = rescore(pool, {name: Reality.parse(r, profile.robots) for name, r in realities.items()})
        write_json_atomic(cache, _table_json(out))
        return out

    tables = tables_of(p.maps_dir / f"scenarios-{key}.json",
                       {k: {"robot": profile.robot, "damage": d} for k, d in damages.items()})
    if worlds:
        trained = {f"{k} in training world {i}": {"robot": profile.robot, "damage": d, "perturbation": draw_world(
            np.random.default_rng([p.seed, TRAIN_STREAM + draw, i]))} for i, (k, d) in enumerate(damages.items())}
        name = f"scenarios-{key}-worlds-{p.seed}" + (f"-{draw}" if draw else "")
        tables = tables | tables_of(p.maps_dir / f"{name}.json", trained)
    return scenario_priors(pool, tables, SCENARIO_MEAN + (" and training worlds" if worlds else ""))


# -- realities --------------------------------------------------------------------------------------

def draw_reality(seed: int, k: int, profile: Profile | None = None) -> dict:
    """Reality k (module doc): its damage type, damage and held-out perturbation."""
    if profile is not None and profile.name != ROBOT:
        return draw_uploaded_reality(seed, k, profile)
    rng = np.random.default_rng([seed, k])
    kind = TYPES[k % len(TYPES)]

    def locked(n: int, skip=()) -> list[dict]:
        out = []
        while len(out) < n:
            leg = f"leg{rng.integers(1, 7)}"
            joint = f"{leg}_{JOINTS[rng.integers(0, 3)]}"
            if leg in skip or any(j["joint"] == joint for j in out):
                continue
            out.append({"leg": leg, "joint": joint, "angle_deg": float(rng.integers(-30, 31))})
        return out

    while True:
        damage: dict = {}
        if kind in ("lost_leg", "lost_leg_and_locked_joint"):
            damage["lost_legs"] = [str(rng.choice(REALITY_LOST))]
        if kind == "locked_joints":
            damage["locked_joints"] = locked(int(rng.integers(1, 3)))
        if kind == "lost_leg_and_locked_joint":
            damage["locked_joints"] = locked(1, skip=damage["lost_legs"])
        if damage not in PRIOR_DAMAGES.values():
            break
    return {"id": f"{seed}-{k}", "type": kind, "reality": {"robot": ROBOT, "damage": damage,
                                                          "perturbation": draw_world(rng)}}


def draw_uploaded_reality(seed: int, k: int, profile: Profile) -> dict:
    """Reality k of an uploaded robot: damage type k mod len(types) of the one damage
    vocabulary (app/robots/damage.py), by its leg map's names: a lost leg, a joint locked at
    a random angle, a weak joint (20-50 % of its torque), a passive joint, a leg shortened by
    15-35 % of its foot segment; never a map's damage; and a held-out world."""
    rng = np.random.default_rng([seed, k])
    kind = profile.types[k % len(profile.types)]
    legs = profile.stored.legs.legs
    while True:
        leg = legs[int(rng.integers(0, len(legs)))]
        joint = leg.joints[int(rng.integers(0, len(leg.joints)))]
        if kind == "lost_leg":
            damage = {"lost_legs": [str(rng.choice(profile.reality_lost))]}
        elif kind == "locked_joint":
            damage = {"locked_joints": [{"leg": leg.name, "joint": joint, "angle_deg": float(rng.integers(-30, 31))}]}
        elif kind == "weak_joint":
            damage = {"weak_joints": [{"leg": leg.name, "joint": joint,
                                       "torque_scale": round(float(rng.uniform(0.2, 0.5)), 3)}]}
        elif kind == "passive_joint":
            damage = {"passive_joints": [{"leg": leg.name, "joint": joint}]}
        else:
            from app.robots.walkable import foot_segment_m

            cut = float(rng.uniform(0.15, 0.35)) * foot_segment_m(profile.stored, leg.name)
            damage = {"shortened_legs": [{"leg": leg.name, "length_m": round(cut, 4)}]}
        if damage not in profile.prior_damages.values():
            break
    return {"id": f"{seed}-{k}", "type": kind, "reality": {"robot": profile.robot, "damage": damage,
                                                          "perturbation": draw_world(rng)}}


def draw_world(rng: np.random.Generator) -> dict:
    """A held-out world: friction, masses, a payload off the trunk's centre, half of them a
    rough floor."""
    rough = bool(rng.random() < 0.5)
    return {"friction_scale": round(float(rng.uniform(0.6, 1.4)), 3),
             "mass_scale": round(float(rng.uniform(0.85, 1.2)), 3),
             "payload_kg": round(float(rng.uniform(0.0, 0.4)), 3),
             "payload_offset_m": [round(float(rng.uniform(-0.04, 0.04)), 3), round(float(rng.uniform(-0.04, 0.04)), 3),
                                  0.0],
             "terrain_amplitude_m": round(float(rng.uniform(0.002, 0.008)), 4) if rough else 0.0,
             "terrain_seed": int(rng.integers(0, 2**31 - 1))}


# -- one reality ------------------------------------------------------------------------------------

def oracle_tables(reality: Reality, reps: list[Repertoire]) -> dict[str, list[Measured]]:
    """Every elite of every map played on the reality: one batched call per map."""
    return {r.map.name: play_many(reality, r, range(len(r.map.forward_m))) for r in reps}


def tried_text(tried: list[tuple[str, int]]) -> str:
    """The gaits an arm tried, in order, as one line: "intact#12, on intact#40"."""
    return ", ".join(f"{m}#{e}" for m, e in tried)


def run_arm(reps: list[Repertoire], tables: dict[str, list[Measured]], s: M.Settings, robot: str,
            stored: Any = None) -> dict:
    out = run_loop(reps, lambda rep, prop: tables[rep.map.name][prop.elite], s, robot, stored=stored)
    d = out.decision
    final = tables[out.rows[d.best_trial].proposal.map][out.rows[d.best_trial].proposal.elite]
    return {"recovered_at": out.recovered_at, "trials": len(out.rows), "stop": d.reason, "method_stopped": d.stop,
            "final_speed_m_s": final.speed_m_s, "final_fell": final.fell,
            "final_lateral_m": final.lateral_m, "final_yaw_deg": final.yaw_deg,
            "tried": tried_text([(r.proposal.map, r.proposal.elite) for r in out.rows])}


def run_random(rep: Repertoire, table: list[Measured], robot: str, seed: int, stored: Any = None) -> dict:
    n = len(table)
    pick = np.random.default_rng(seed).permutation(n)[:MAX_TRIALS]
    ms = [table[i] for i in pick]
    at = next((k + 1 for k, m in enumerate(ms) if recovered(m.forward_m, m.fell, m.duration_s, robot, stored)), None)
    best = max(ms, key=lambda m: m.speed_m_s)
    return {"recovered_at": at, "trials": len(ms), "stop": f"{len(ms)} random elites of {rep.map.name}",
            "method_stopped": True, "final_speed_m_s": best.speed_m_s, "final_fell": best.fell,
            "final_lateral_m": best.lateral_m, "final_yaw_deg": best.yaw_deg,
            "tried": tried_text([(rep.map.name, int(i)) for i in pick])}


def _table_json(tables: dict[str, list[Measured]]) -> dict:
    return {k: [[m.forward_m, m.lateral_m, m.yaw_deg, m.fell, m.duration_s] for m in ms] for k, ms in tables.items()}


def _table_read(data: dict) -> dict[str, list[Measured]]:
    return {k: [Measured(float(a), float(b), float(c), bool(d), float(e)) for a, b, c, d, e in ms]
            for k, ms in data.items()}


def evaluate_reality(drawn: dict, reps: list[Repertoire], seed: int, cache: Path | None = None,
                     scenarios: list[Repertoire] | None = None, worlds: list[Repertoire] | None = None,
                     worlds_2: list[Repertoire] | None = None, profile: Profile | None = None) -> dict:
    """The oracle and every arm on one reality. ``cache``: where the oracle table of the
    reality is kept (under --maps-dir), so arms can be re-run on it without simulating;
    ``scenarios``: ``scenario_maps`` (the pooled elites: their table is the maps' tables end
    to end)."""
    t0 = time.perf_counter()
    reality = Reality.parse(drawn["reality"], profile.robots if profile is not None else None)
    if cache is not None and cache.exists():
        tables = _table_read(json.loads(cache.read_text()))
    else:
        tables = oracle_tables(reality, reps)
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            write_json_atomic(cache, _table_json(tables))
    t_oracle = time.perf_counter() - t0
    target = target_speed(reality.robot, reality.stored)
    per_map = {}
    for name, ms in list(tables.items()):
        speeds = [m.speed_m_s for m in ms]
        per_map[name] = {"best_speed_m_s": max(speeds), "recovering_elites": int(sum(s >= target for s in speeds)),
                         "elites": len(ms)}
    arms = {}
    sets = {"ite": reps[:1], "all": reps}
    if scenarios:
        pooled = [m for r in reps for m in tables[r.map.name]]
        tables = tables | {r.map.name: pooled for r in scenarios}
        sets |= {"scenarios": scenarios, "expected": scenarios[:1]}
    if worlds:
        pooled = [m for r in reps for m in tables[r.map.name]]
        tables = tables | {r.map.name: pooled for r in worlds}
        sets |= {"worlds": worlds, "expected_worlds": worlds[:1]}
    if worlds_2:
        pooled = [m for r in reps for m in tables[r.map.name]]
        tables = tables | {r.map.name: pooled for r in worlds_2}
        sets |= {"worlds_2": worlds_2}
    for name, (_, s, which, stated) in ARMS.items():
        if which not in sets:
            continue
        s = dataclasses.replace(s, target_m_s=target) if stated else s
        arms[name] = run_arm(sets[which], tables, s, reality.robot, reality.stored)
    arms[RANDOM] = run_random(reps[0], tables[reps[0].map.name], reality.robot, seed, reality.stored)
    from scipy.stats import spearmanr

    ite_speeds = [m.speed_m_s for m in tables[reps[0].map.name]]
    rho = spearmanr(reps[0].map.forward_m, ite_speeds)[0] if len(set(ite_speeds)) > 1 else float("nan")
    oracle = {"best_speed_m_s": max(v["best_speed_m_s"] for v in per_map.values()),
              "ite_map_best_speed_m_s": per_map[reps[0].map.name]["best_speed_m_s"],
              "ite_map_rank_correlation": None if rho != rho else float(rho), "maps": per_map}
    return drawn | {"target_m_s": target, "oracle": oracle,
                    "arms": arms, "seconds": {"oracle": t_oracle, "total": time.perf_counter() - t0}}


# -- the command ------------------------------------------------------------------------------------

def _commit() -> str:
    try:
        c = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, timeout=10)
        return c.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


# what a continued run must share with the file's realities (the rest, e.g. the arms, is re-run on kept tables)
SAME = ("robot", "seed", "quick", "max_trials", "map_budget", "maps", "types", "prior_damages", "reality_lost_legs")
# the realities whose results were seen while the arms after ``gaitmend`` were designed (in the file's order):
# the page reports the rest apart, as held out from the design
DESIGN_SEEN = 21


def _table_path(p: Params, profile: Profile, reality_id: str) -> Path:
    """Where a reality's oracle table is kept (the hexapod's under its id alone, as before)."""
    name = reality_id if profile.name == ROBOT else f"{profile.name}-{reality_id}"
    return p.maps_dir / "tables" / f"{name}.json"


def setup(p: Params, maps: list[dict]) -> dict:
    profile = profile_of(p.robot)
    extra = {} if profile.stored is None else {"robot_id": profile.robot, "uploaded": True}
    return {"robot": profile.name, **extra, "seed": p.seed, "quick": p.quick, "max_trials": MAX_TRIALS,
            "map_budget": QUICK_BUDGET if p.quick else MAP_BUDGET, "maps": maps,
            "arms": {k: {"words": w, "settings": dataclasses.asdict(s), "maps": which, "target_stated": stated}
                     for k, (w, s, which, stated) in ARMS.items()}
            | {RANDOM: {"words": f"{MAX_TRIALS} elites of ITE's map drawn uniformly without replacement"}},
            "de_believed": de_setup(p.quick), "design_seen": profile.design_seen, "types": list(profile.types),
            "prior_damages": profile.prior_damages,
            "reality_lost_legs": list(profile.reality_lost)}


def reproduce(p: Params, log: Callable[[str], None] = print) -> str:
    profile = profile_of(p.robot)
    if p.de_only:
        data = json.loads(p.json_out.read_text()) if p.json_out.exists() else None
        if data is None or data["setup"]["quick"] != p.quick or data["setup"]["seed"] != p.seed:
            raise SystemExit(f"--de-only runs the DE arm on the realities of {p.json_out}: it holds none of this "
                             "setup (seed, quick)")
        return de_pass(p, profile, data, log)
    reps, maps = build_maps(p, log)
    scenarios = scenario_maps(p, reps, log)
    worlds = scenario_maps(p, reps, log, worlds=True)
    worlds_2 = scenario_maps(p, reps, log, worlds=True, draw=1)
    want = setup(p, maps)
    want = json.loads(json.dumps(want))
    data = json.loads(p.json_out.read_text()) if p.json_out.exists() else None
    same = lambda a, b: all(a.get(k) == b.get(k) for k in SAME)  # noqa: E731
    if data is not None and not same(data["setup"], want):
        raise SystemExit(f"{p.json_out} holds realities of another setup (maps, budget or seed): move it aside "
                         "to start afresh")
    if data is None:
        data = {"schema": SCHEMA, "experiment": "adapt" if profile.name == ROBOT else f"adapt-{profile.name}",
                "command": COMMAND if profile.name == ROBOT else ANT_COMMAND, "setup": want, "realities": []}
    if _arms_setup(data["setup"]) != _arms_setup(want):  # arms changed: re-run them where the table is kept
        data["setup"] = want
        for i, r in enumerate(data["realities"]):
            cache = _table_path(p, profile, r["id"])
            if cache.exists():
                k = int(r["id"].rsplit("-", 1)[1])
                row = evaluate_reality({x: r[x] for x in ("id", "type", "reality")}, reps, p.seed * 100_003 + k, cache,
                                       scenarios, worlds, worlds_2, profile)
                de = {DE_ARM: r["arms"][DE_ARM]} if DE_ARM in r["arms"] else {}
                data["realities"][i] = r | {k: row[k] for k in ("arms", "oracle", "target_m_s")}
                data["realities"][i]["arms"] |= de
                log(f"reality {r['id']}: arms re-run on its kept table")
        data["realities"] = [r for r in data["realities"]
                             if set(r["arms"]) - {DE_ARM} == set(want["arms"]) | {RANDOM}]
    data["setup"] = want | {"de_believed": data["setup"].get("de_believed")}  # the DE pass checks its own entry
    write_json_atomic(p.json_out, data)
    have = {r["id"] for r in data["realities"]}
    for k in range(p.realities):
        drawn = draw_reality(p.seed, k, profile)
        if drawn["id"] in have:
            continue
        if p.stop_at and time.time() > p.stop_at:
            log(f"stopping before reality {drawn['id']}: --stop-at passed")
            break
        log(f"reality {drawn['id']} ({drawn['type']}, load {os.getloadavg()[0]:.1f}) ...")
        row = evaluate_reality(drawn, reps, p.seed * 100_003 + k, _table_path(p, profile, drawn["id"]),
                               scenarios, worlds, worlds_2, profile)
        row |= {"commit": _commit(), "machine": machine(), "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        data["realities"].append(row)
        write_json_atomic(p.json_out, data)
        log(f"reality {drawn['id']}: {row['seconds']['total']:.0f} s, "
            + ", ".join(f"{a} {v['recovered_at']}" for a, v in row["arms"].items()))
    return de_pass(p, profile, data, log)


def _arms_setup(setup: dict) -> dict:
    """The setup but for the DE arm's entry: what the arms read from the maps' tables."""
    return {k: v for k, v in setup.items() if k != "de_believed"}

"""Run a ``freegait`` job: the walk, its controls on the same field, its robustness cases.

Every unit is one MuJoCo walk (``app.jobs.freegait.planner.walk``). Controls: the planner with
the zones ignored (or known, when the job's planner ignores them), a periodic alternating
tripod with fixed footholds (no foothold planner at all), and Ev replaced by a uniformly
random valid tripod (so what Eq. 24 earns is measured). Robustness: the same walk with the
planner's ground-height estimate off by +-I_T/2, friction x0.7 and x1.3, every mass +10 %,
and the physics timestep halved. Each unit's summary is checkpointed; the walk and the
first control are re-simulated on a resume for their traces (same numbers: deterministic).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.freegait.spec import ROBUSTNESS_CASES, FreegaitSpec
from app.jobs.freegait.planner.walk import STOP_CAUSES, WalkConfig, WalkResult, stand_pose, walk, zones_near_route
from app.robots.silo6 import SILO6
from app.jobs.freegait.terrain import Minefield, Terrain, make_minefield, make_terrain

TARGET = "finishes the route, 0 footholds in forbidden zones, SM > SM_min throughout"
CONTROL_LABELS = {
    "unaware": "same planner, forbidden zones ignored (Fig. 9a)",
    "aware": "same planner, forbidden zones known",
    "periodic": "periodic alternating tripod, fixed footholds, no foothold planner",
    "random_valid": "foothold planner with Ev replaced by a random valid tripod",
}
ROBUST_LABELS = {
    "ground_error_+": "planner's ground estimate I_T/2 too high",
    "ground_error_-": "planner's ground estimate I_T/2 too low",
    "friction_0.7": "friction x0.7",
    "friction_1.3": "friction x1.3",
    "mass_+10pct": "every mass +10 %",
    "dt_half": "physics timestep halved (1 ms)",
    "dt_quarter": "physics timestep quartered (0.5 ms)",
}
METRICS = ("finished", "footholds_in_zones", "footholds_in_safe_areas", "closest_zone_m", "min_sm_m", "min_k_r_m",
           "stop_time_s", "mean_speed_m_s", "tracking_error_max_m", "foothold_error_max_m", "transfers",
           "failed_touchdowns", "time_s")


def world(spec: FreegaitSpec) -> tuple[Terrain, Minefield]:
    t = spec.terrain
    terrain = make_terrain(t.x_range(), t.y_range(), t.roughness_m, t.seed)
    _, feet = stand_pose(SILO6, terrain)
    f = spec.forbidden
    field = make_minefield(terrain, f.density_per_m2, f.zone_diameter_m, f.safe_diameter_m, f.seed, cleared=feet[:, :2])
    return terrain, field


def config(spec: FreegaitSpec, **kw) -> WalkConfig:
    base = WalkConfig(route=spec.route.build(), params=spec.params(), aware=spec.forbidden.known, seed=spec.seed)
    return dataclasses.replace(base, **kw)


def unit_configs(spec: FreegaitSpec) -> list[tuple[str, str, WalkConfig]]:
    """(group, name, config) of every unit in run order: the walk, controls, robustness."""
    units = [("walk", "walk", config(spec))]
    if spec.evidence.controls:
        other = "unaware" if spec.forbidden.known else "aware"
        units += [("control", other, config(spec, aware=not spec.forbidden.known)),
                  ("control", "periodic", config(spec, chooser="periodic")),
                  ("control", "random_valid", config(spec, chooser="random"))]
    if spec.evidence.robustness:
        half = spec.terrain.roughness_m / 2
        kws = {"ground_error_+": {"ground_bias": half}, "ground_error_-": {"ground_bias": -half},
               "friction_0.7": {"friction_scale": 0.7}, "friction_1.3": {"friction_scale": 1.3},
               "mass_+10pct": {"mass_scale": 1.1}, "dt_half": {"timestep": 0.001},
               "dt_quarter": {"timestep": 0.0005}}
        units += [("robustness", n, config(spec, **kws[n])) for n in ROBUSTNESS_CASES]
    return units


def target_met(s: dict, sm_min: float) -> bool:
    return bool(s["finished"] and s["footholds_in_zones"] == 0 and s["min_sm_m"] is not None and s["min_sm_m"] > sm_min)


def _metrics(s: dict) -> dict:
    return {k: s[k] for k in METRICS}


def trace_of(r: WalkResult) -> dict[str, np.ndarray]:
    s = r.steps
    return {"time_s": s["t"], "pos": s["pos"], "rpy": s["rpy"], "phase": s["phase"], "sm_m": s["sm"], "k_r_m": s["k_r"],
            "v_bh": s["v"], "stop": s["stop"], "progress_m": s["progress"], "cmd_xy": s["cmd_xy"],
            "track_err_m": s["track_err"], "k_ev": s["k_ev"], "crab_deg": s["crab_deg"], "qpos": s["qpos"],
            "tips": s["tips"]}


def footholds_out(r: WalkResult) -> list[dict]:
    return [{k: (round(v, 4) if isinstance(v, float) else v) for k, v in f.items()} for f in r.footholds]


def run(spec: FreegaitSpec, ctx: RunContext) -> JobResult:
    t0 = time.perf_counter()
    ckpt = ctx.load_checkpoint() or {}
    done: dict[str, dict] = ckpt.get("units", {})
    wall_before = ckpt.get("wall_s", 0.0)
    terrain, field = world(spec)
    units = unit_configs(spec)
    total = len(units)
    keep: dict[str, WalkResult] = {}
    sim_steps = ckpt.get("sim_steps", 0)

    for i, (group, name, cfg) in enumerate(units):
        if ctx.is_cancelled():
            raise Cancelled()
        need_trace = i <= 1  # the walk and the first control are drawn and replayed
        if name in done and not need_trace:
            continue
        r = walk(terrain, field, cfg, cancel=ctx.is_cancelled)
        if r.outcome == "cancelled":
            raise Cancelled()
        if need_trace:
            keep[name] = r
        if name not in done:
            s = r.summary()
            done[name] = {"group": group, "summary": s, "footholds": footholds_out(r) if need_trace else None}
            sim_steps += r.sim_steps
            ctx.save_checkpoint({"units": done, "wall_s": wall_before + time.perf_counter() - t0, "sim_steps": sim_steps})
        s = done[name]["summary"]
        ctx.progress(i + 1, total, {"run": name, "finished": s["finished"], "in_zones": s["footholds_in_zones"],
                                    "min_sm_m": s["min_sm_m"]})

    main = keep["walk"]
    ms = done["walk"]["summary"]
    sm_min = spec.planner.sm_min_m
    controls = []
    for group, name, _ in units:
        if group != "control":
            continue
        s = done[name]["summary"]
        note = {"unaware": "the same field and route; footholds are checked against the zones after the fact",
                "aware": "the same field and route with the zones known",
                "periodic": "no search: each leg steps to a fixed point of its workspace; lifts alternate",
                "random_valid": f"random draws from the job seed {spec.seed}"}[name]
        controls.append({"name": name, "label": CONTROL_LABELS[name], "evaluations": 1, "metrics": _metrics(s),
                         "target_met": target_met(s, sm_min), "note": note})
    robustness = None
    if spec.evidence.robustness:
        cases = [{"name": n, "label": ROBUST_LABELS[n], "metrics": _metrics(done[n]["summary"]),
                  "target_met": target_met(done[n]["summary"], sm_min)} for n in ROBUSTNESS_CASES]
        spread = {}
        for m in ("footholds_in_zones", "min_sm_m", "stop_time_s", "mean_speed_m_s", "tracking_error_max_m"):
            vals = [c["metrics"][m] for c in cases if c["metrics"][m] is not None]
            spread[m] = {"min": min(vals, default=None), "max": max(vals, default=None), "nominal": ms[m]}
        robustness = {"target": TARGET, "cases": cases, "met": sum(c["target_met"] for c in cases), "total": len(cases),
                      "spread": spread}

    wall = wall_before + time.perf_counter() - t0
    first_control = next((n for g, n, _ in units if g == "control"), None)
    summary = {
        "kind": "freegait", "robot": spec.robot, "seed": spec.seed,
        "route": spec.route.model_dump(), "gait": spec.route.gait, "aware": spec.forbidden.known,
        "sm_min_m": sm_min, "k_ev": spec.planner.k_ev, "candidates_per_leg": spec.planner.candidates_per_leg,
        "field": {"zones": int(len(field.centres)), "density_per_m2": spec.forbidden.density_per_m2,
                  "zone_radius_m": field.zone_radius, "safe_radius_m": field.safe_radius,
                  "x_range_m": list(terrain.x_range), "y_range_m": list(terrain.y_range),
                  "roughness_m": terrain.roughness},
        "zones": np.round(zones_near_route(field, spec.route.build()).centres, 4).tolist(),  # drawn ones
        **{k: ms[k] for k in ms},
        "target": TARGET, "target_met": target_met(ms, sm_min),
        "stop_causes": list(STOP_CAUSES[1:]),
        "footholds_list": done["walk"]["footholds"],
        "control_footholds": {"name": first_control, "footholds": done[first_control]["footholds"]} if first_control else None,
        "controls": controls,
        "timing": {"wall_s": wall, "sim_steps": sim_steps, "sim_time_s": ms["time_s"],
                   "realtime_factor": ms["time_s"] / max(ms["wall_s"], 1e-9)},
    }
    summary.pop("wall_s", None)
    if robustness is not None:
        summary["robustness"] = robustness
    # one row per transfer; its number is the history's x column (Kind.history_x). A row's
    # "index" is the chosen candidate of each leg, not a number: it stays out of history.csv.
    history = [{"transfer": i} | {k: v for k, v in row.items() if k != "index"} for i, row in enumerate(main.transfers)]
    traces = {"walk": trace_of(main)}
    if first_control:
        traces[first_control] = trace_of(keep[first_control])
    return JobResult(summary=summary, history=history, traces=traces, model_xml=main.model_xml,
                     evaluations=len(done), sim_steps=sim_steps)

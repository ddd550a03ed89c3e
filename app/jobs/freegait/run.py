"""Run a ``freegait`` job: the walk, its controls on the same field, its robustness cases.

Every unit is one MuJoCo walk (``app.jobs.freegait.planner.walk``). Controls: the planner with
the zones ignored (or known, when the job's planner ignores them), a periodic alternating
tripod with fixed footholds (no foothold planner at all), and Ev replaced by a uniformly
random valid tripod (so what Eq. 24 earns is measured). Robustness: the same walk with the
planner's ground-height estimate off by +-I_T/2, friction x0.7 and x1.3, every mass +10 %,
and the physics timestep halved and quartered. The three groups are the job's phases
(``evidence.Phases``): each unit's summary lands in its phase's checkpoint entry; the walk
and the first control are re-simulated on a resume for their traces (same numbers:
deterministic).

Steps: ``set_up`` (world, units, what a resumed job already has), ``run_phase`` for the
walk, the controls and the robustness re-runs, then ``control_rows``, ``robustness_block``
and ``result``.
"""

from __future__ import annotations

import dataclasses
import time
from typing import NamedTuple

import numpy as np

from app.jobs import evidence
from app.jobs.base import Cancelled, JobResult, RunContext
from app.jobs.evidence import Case, CaseResult, ControlRow, PhaseContext, Phases, Robustness
from app.jobs.freegait.planner.walk import STOP_CAUSES, WalkConfig, WalkResult, stand_pose, walk, zones_near_route
from app.jobs.freegait.spec import ROBUSTNESS_CASES, TARGET, FreegaitSpec, GroundError, target_met
from app.jobs.freegait.terrain import Minefield, Terrain, make_minefield, make_terrain
from app.robots.silo6 import SILO6

CONTROLS = {  # name: (label, note)
    "unaware": ("same planner, forbidden zones ignored (Fig. 9a)",
                "the same field and route; footholds are checked against the zones after the fact"),
    "aware": ("same planner, forbidden zones known", "the same field and route with the zones known"),
    "periodic": ("periodic alternating tripod, fixed footholds, no foothold planner",
                 "no search: each leg steps to a fixed point of its workspace; lifts alternate"),
    "random_valid": ("foothold planner with Ev replaced by a random valid tripod",
                     "random draws from the job seed {seed}"),
}
METRICS = ("finished", "footholds_in_zones", "footholds_in_safe_areas", "closest_zone_m", "min_sm_m", "min_k_r_m",
           "stop_time_s", "mean_speed_m_s", "tracking_error_max_m", "foothold_error_max_m", "transfers",
           "failed_touchdowns", "time_s")
SPREAD_KEYS = ("footholds_in_zones", "min_sm_m", "stop_time_s", "mean_speed_m_s", "tracking_error_max_m")


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


def case_config(spec: FreegaitSpec, case: Case) -> WalkConfig:
    """The walk under one robustness case: the standard scales applied to the walk's world,
    the kind's own ground-estimate error as the planner's ground bias."""
    base = config(spec)
    bias = case.sign * (spec.terrain.roughness_m / 2) if isinstance(case, GroundError) else base.ground_bias
    return dataclasses.replace(base, ground_bias=bias, friction_scale=base.friction_scale * case.friction_scale,
                               mass_scale=base.mass_scale * case.mass_scale,
                               timestep=base.timestep * case.timestep_scale)


class Unit(NamedTuple):
    group: str  # its phase: walk, control or robustness
    name: str
    cfg: WalkConfig


def unit_configs(spec: FreegaitSpec) -> list[Unit]:
    """Every unit in run order: the walk, controls, robustness."""
    units = [Unit("walk", "walk", config(spec))]
    if spec.evidence.controls:
        other = "unaware" if spec.forbidden.known else "aware"
        units += [Unit("control", other, config(spec, aware=not spec.forbidden.known)),
                  Unit("control", "periodic", config(spec, chooser="periodic")),
                  Unit("control", "random_valid", config(spec, chooser="random"))]
    if spec.evidence.robustness:
        units += [Unit("robustness", c.name, case_config(spec, c)) for c in ROBUSTNESS_CASES]
    return units


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


@dataclasses.dataclass
class Job:
    """A freegait job under way: its world, its units and what they gave so far."""

    spec: FreegaitSpec
    terrain: Terrain
    field: Minefield
    units: list[Unit]
    phases: Phases
    done: dict[str, dict]  # unit name -> {"summary", "footholds"}, as checkpointed
    wall_before: float  # wall time of the attempts before a resume
    t0: float
    keep: dict[str, WalkResult] = dataclasses.field(default_factory=dict)  # the walks the result draws

    def of(self, group: str) -> list[Unit]:
        return [u for u in self.units if u.group == group]

    @property
    def first_control(self) -> str | None:
        return next((u.name for u in self.of("control")), None)

    def summary(self, name: str) -> dict:
        return self.done[name]["summary"]

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.t0


def set_up(spec: FreegaitSpec, ctx: RunContext) -> Job:
    t0 = time.perf_counter()
    terrain, field = world(spec)
    units = unit_configs(spec)
    sizes: dict[str, int] = {}
    for u in units:
        sizes[u.group] = sizes.get(u.group, 0) + 1
    phases = Phases(ctx, sizes)
    saved = [phases.context(g).load_checkpoint() or {} for g in sizes]
    done = {name: unit for entry in saved for name, unit in entry.get("units", {}).items()}
    wall_before = max((entry.get("wall_s", 0.0) for entry in saved), default=0.0)
    return Job(spec, terrain, field, units, phases, done, wall_before, t0)


def run_phase(job: Job, group: str) -> None:
    """The units of one phase in order, each checkpointed in the phase's entry and counted
    on the progress bar; a unit a resumed job already has runs again only to be drawn."""
    pc = job.phases.context(group)
    entry = {"units": {u.name: job.done[u.name] for u in job.of(group) if u.name in job.done}}
    for u in job.of(group):
        pc.check()
        _run_unit(job, pc, u, entry)
        s = job.summary(u.name)
        pc.tick(1, {"run": u.name, "finished": s["finished"], "in_zones": s["footholds_in_zones"],
                    "min_sm_m": s["min_sm_m"]})


def _run_unit(job: Job, pc: PhaseContext, u: Unit, entry: dict) -> None:
    drawn = u.name in ("walk", job.first_control)  # the result holds their traces and footholds
    if u.name in job.done and not drawn:
        return
    r = walk(job.terrain, job.field, u.cfg, cancel=pc.is_cancelled)
    if r.outcome == "cancelled":
        raise Cancelled()
    if drawn:
        job.keep[u.name] = r
    if u.name not in job.done:
        job.done[u.name] = entry["units"][u.name] = {"summary": r.summary(),
                                                     "footholds": footholds_out(r) if drawn else None}
        entry["wall_s"] = job.wall()
        pc.save_checkpoint(entry)


def control_rows(job: Job) -> list[dict]:
    sm_min = job.spec.planner.sm_min_m
    rows = []
    for u in job.of("control"):
        s = job.summary(u.name)
        label, note = CONTROLS[u.name]
        rows.append(ControlRow(u.name, label, _metrics(s), target_met(s, sm_min), evaluations=1,
                               note=note.format(seed=job.spec.seed)).to_json())
    return rows


def robustness_block(job: Job) -> dict | None:
    if not job.spec.evidence.robustness:
        return None
    sm_min = job.spec.planner.sm_min_m
    cases = [CaseResult(c.name, c.label, _metrics(job.summary(c.name)), target_met(job.summary(c.name), sm_min))
             for c in ROBUSTNESS_CASES]
    # The spread is the range over the re-simulations alone, the nominal walk's value beside
    # it (not inside the range, as evidence.spread would put it: these are the numbers every
    # freegait result has shown).
    over_cases = evidence.spread({}, [c.to_json() for c in cases], SPREAD_KEYS, as_float=False)
    nominal = job.summary("walk")
    spread = {k: {"min": over_cases.get(k, {}).get("min"), "max": over_cases.get(k, {}).get("max"),
                  "nominal": nominal[k]} for k in SPREAD_KEYS}
    return Robustness(TARGET.text, cases, spread).to_json()


def result(job: Job, controls: list[dict], robustness: dict | None) -> JobResult:
    spec, terrain, field = job.spec, job.terrain, job.field
    ms = job.summary("walk")
    first_control = job.first_control
    sim_steps = sum(unit["summary"]["sim_steps"] for unit in job.done.values())
    summary = {
        "kind": "freegait", "robot": spec.robot, "seed": spec.seed,
        "route": spec.route.model_dump(), "gait": spec.route.gait, "aware": spec.forbidden.known,
        "sm_min_m": spec.planner.sm_min_m, "k_ev": spec.planner.k_ev, "candidates_per_leg": spec.planner.candidates_per_leg,
        "field": {"zones": int(len(field.centres)), "density_per_m2": spec.forbidden.density_per_m2,
                  "zone_radius_m": field.zone_radius, "safe_radius_m": field.safe_radius,
                  "x_range_m": list(terrain.x_range), "y_range_m": list(terrain.y_range),
                  "roughness_m": terrain.roughness},
        "zones": np.round(zones_near_route(field, spec.route.build()).centres, 4).tolist(),  # drawn ones
        **{k: ms[k] for k in ms},
        "target": TARGET.text, "target_met": target_met(ms, spec.planner.sm_min_m),
        "stop_causes": list(STOP_CAUSES[1:]),
        "footholds_list": job.done["walk"]["footholds"],
        "control_footholds": {"name": first_control, "footholds": job.done[first_control]["footholds"]} if first_control else None,
        "controls": controls,
        "timing": {"wall_s": job.wall(), "sim_steps": sim_steps, "sim_time_s": ms["time_s"],
                   "realtime_factor": ms["time_s"] / max(ms["wall_s"], 1e-9)},
    }
    summary.pop("wall_s", None)
    if robustness is not None:
        summary["robustness"] = robustness
    main = job.keep["walk"]
    # one row per transfer; its number is the history's x column (Kind.history_x). A row's
    # "index" is the chosen candidate of each leg, not a number: it stays out of history.csv.
    history = [{"transfer": i} | {k: v for k, v in row.items() if k != "index"} for i, row in enumerate(main.transfers)]
    traces = {"walk": trace_of(main)}
    if first_control:
        traces[first_control] = trace_of(job.keep[first_control])
    return JobResult(summary=summary, history=history, traces=traces, model_xml=main.model_xml,
                     evaluations=len(job.done), sim_steps=sim_steps)


def run(spec: FreegaitSpec, ctx: RunContext) -> JobResult:
    job = set_up(spec, ctx)
    for group in job.phases.sizes:
        run_phase(job, group)
    # no phases.finish(): every unit ticks, so the last one's report is already the full bar
    return result(job, control_rows(job), robustness_block(job))

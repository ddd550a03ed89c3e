"""The paper's three simulation examples (Sec. 5.1), circling and spinning runs, the density
sweep beyond the paper, and the walk under localisation and zone-position errors (issue
28): ``gaitmend reproduce freegait`` (k_ev, the first), ``freegait-zones``,
``freegait-crab``, ``freegait-circling``, ``freegait-spinning``, ``freegait-sweep``,
``freegait-noise``. Each appends its finished runs to its JSON under docs/ (a re-run skips
them: ``--write-docs``) and docs/freegait.md's generated sections are rendered from those
files alone. The runs live by what they reproduce: paper_examples.py (k_ev, zones, crab, circling,
spinning), beyond_paper.py (the density sweep, the walk under errors), this module (the
default job through `gaitmend run`'s code) and bench.py (what `gaitmend bench` measures);
walks.py holds what they share. ``EXPERIMENTS`` and ``BENCH`` are the kind's hooks."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.base import Experiment
from app.jobs.ledger import current_runs
from app.jobs.evidence import controls_of, robustness_of
from app.jobs.reporting import Section, md_table, missing, progress_note, yes
from app.jobs.freegait.reproduce.beyond_paper import (NOISE_JSON, SWEEP_JSON, NoiseParams, SweepParams, noise,
                                                      render_noise, render_noise_summary, render_sweep, sweep)
from app.jobs.freegait.reproduce.bench import BENCH  # noqa: F401 (the kind's bench hook reads it here)
from app.jobs.freegait.reproduce.paper_examples import (CIRCLING_JSON, CRAB_JSON, KEV_JSON, SPINNING_JSON, ZONES_JSON,
                                                        CrabParams, KevParams, SpinParams, TurnParams, ZonesParams,
                                                        circling, crab, kev, render_crab, render_kev, render_turn,
                                                        render_zones, spinning, zones)
from app.jobs.freegait.reproduce.walks import SCIENCE, _cmd, _f, _ledger, _world  # noqa: F401 (_world: re-exported)


# -- issue 28: one job, its controls and its robustness, through `gaitmend run`'s code ----------

JOB_JSON = "docs/freegait_job.json"
JOB_SCIENCE = (*SCIENCE, "app/jobs/freegait/run.py", "app/jobs/freegait/spec.py")
JOB_DROP = ("footholds_list", "control_footholds", "zones")  # per-foothold lists: the bundle's, not the page's


class JobParams(BaseModel):
    densities: str = Field("3,8", description="zones per m^2 of each job, every other field at the spec's default "
                                              "(3: the default job, {\"kind\": \"freegait\"})")
    json_out: Path | None = Field(Path(JOB_JSON), description="the ledger: one job (walk, controls, robustness) per "
                                                              "density")


def job_spec(density: float) -> dict:
    """The full spec (every default filled in) of ``{"kind": "freegait"}`` at ``density``."""
    from app.jobs.freegait.spec import FreegaitSpec

    return FreegaitSpec.parse({"kind": "freegait", "forbidden": {"density_per_m2": density}}).model_dump(mode="json")


def _job_run(spec: dict) -> dict:
    """The job as `gaitmend run` runs it (the kind's ``run``, app/jobs/freegait/run.py, in a
    context with no outside world); its summary without the per-foothold lists."""
    from app.jobs.base import MemoryContext
    from app.jobs.freegait.run import run
    from app.jobs.freegait.spec import FreegaitSpec

    s = run(FreegaitSpec.parse(spec), MemoryContext()).summary
    return {k: v for k, v in s.items() if k not in JOB_DROP}


def job(p: JobParams, log: Callable[[str], None]) -> str:
    densities = [float(d) for d in p.densities.split(",") if d.strip()]
    led = _ledger(p, "job", len(densities))
    for d in densities:
        spec = job_spec(d)
        log(f"freegait job at {d:g} zones/m^2: the walk, 3 controls, 7 robustness re-simulations ...")
        led.run(f"job {d:g}", spec, spec["seed"], lambda spec=spec: _job_run(spec), log)
    return render_job([led.data])


_JOB_COLS = ["finished", "in zones", "in safe areas", "min SM (m)", "min K_R (m)", "stopped (s)", "transfers",
             "tracking error max (m)"]


def _job_cells(name: str, m: dict) -> list[str]:
    return [name, yes(m["finished"]), str(m["footholds_in_zones"]), str(m["footholds_in_safe_areas"]), _f(m["min_sm_m"]),
            _f(m["min_k_r_m"]), _f(m["stop_time_s"], "{:.1f}"), str(m["transfers"]), _f(m["tracking_error_max_m"])]


def _job_runs(data: dict | None) -> list[tuple[dict, dict]]:
    """(run row, summary) of each finished job, by zone density."""
    rows = current_runs(data) if data else []
    return sorted(((r, r["result"]) for r in rows), key=lambda rs: rs[1]["field"]["density_per_m2"])


def _job_reading(s: dict) -> list[str]:
    """What the controls show against the walk, each number from the summary."""
    ctl = {c.name: c.metrics for c in controls_of(s)}
    out = []
    if "periodic" in ctl:
        c = ctl["periodic"]
        out.append(f"- periodic tripod: {c['transfers']} transfers against the walk's {s['transfers']}, minimum SM "
                   f"{_f(c['min_sm_m'])} against {_f(s['min_sm_m'])} m, tracking error max "
                   f"{_f(c['tracking_error_max_m'])} against {_f(s['tracking_error_max_m'])} m")
    if "random_valid" in ctl:
        c = ctl["random_valid"]
        out.append(f"- random valid tripod (Ev switched off): {c['transfers']} transfers, minimum SM {_f(c['min_sm_m'])} m, "
                   f"minimum K_R {_f(c['min_k_r_m'])} m, body stopped {_f(c['stop_time_s'], '{:.1f}')} s")
    for name in ("unaware", "aware"):
        if name in ctl:
            out.append(f"- {name} control: footholds in zones {ctl[name]['footholds_in_zones']}, in safe areas "
                       f"{ctl[name]['footholds_in_safe_areas']} (the walk: {s['footholds_in_zones']}, "
                       f"{s['footholds_in_safe_areas']})")
    out.append(f"- the walk's closest foot centre to a zone centre: {_f(s['closest_zone_m'])} m (zone radius "
               f"{s['field']['zone_radius_m']:g} m, safe radius {s['field']['safe_radius_m']:g} m); touchdowns within "
               f"{_f(s['foothold_error_max_m'])} m of the planned point")
    return out


def _job_robustness(s: dict) -> list[str]:
    rb = robustness_of(s)
    if rb is None:
        return []
    rows = [_job_cells("nominal", s)] + [_job_cells(c.label, c.metrics) for c in rb.cases]
    moved = {k: max((abs(c.metrics[k] - s[k]) for c in rb.cases if c.metrics.get(k) is not None), default=None)
             for k in ("min_sm_m", "tracking_error_max_m")}
    same = sum(c.metrics["transfers"] == s["transfers"] and c.metrics["footholds_in_zones"] == s["footholds_in_zones"]
               for c in rb.cases)
    return [f"Robustness (the walk re-simulated; target: {rb.target}): {rb.met} of {rb.total} cases meet it.", "",
            md_table(["case", *_JOB_COLS], rows),
            f"Largest change from the nominal walk over the cases: minimum SM {_f(moved['min_sm_m'])} m, tracking "
            f"error max {_f(moved['tracking_error_max_m'])} m; {same} of {rb.total} cases keep the walk's transfers and "
            "footholds-in-zones counts.", ""]


def render_job(datas: list) -> str:
    data = datas[0]
    runs = _job_runs(data)
    if not runs:
        return missing(JOB_JSON, _cmd("job"))
    out = []
    for row, s in runs:
        f, r = s["field"], s["route"]
        x, y = f["x_range_m"], f["y_range_m"]
        out += [f"**{f['density_per_m2']:g} zones/m^2** ({f['zones']} zones over the {x[1] - x[0]:g} x {y[1] - y[0]:g} m "
                f"terrain, {r['distance_m']:g} m at {r['speed_m_s']:g} m/s, ground {f['roughness_m']:g} m peak to valley; "
                f"the job's walks took {row['wall_s']:.0f} s wall, {row['cpu_s']:.0f} s CPU):", "",
                md_table(["run", *_JOB_COLS], [_job_cells("walk (zones known)", s)]
                         + [_job_cells(f"control: {c.label}", c.metrics) for c in controls_of(s)]),
                "Read from the controls:", "", *_job_reading(s), "", *_job_robustness(s)]
    return "\n".join(out) + progress_note(data, len(runs))


EXPERIMENTS = [
    Experiment("kev", "Example 1 (Fig. 8): k_ev in 0..0.1 stepped every 30 s; phase durations, SM and K_R per k_ev",
               KevParams, kev, (Section("freegait-kev", (KEV_JSON,), render_kev),)),
    Experiment("zones", "Example 2 (Fig. 9): random forbidden zones, planner aware vs unaware on the same fields",
               ZonesParams, zones, (Section("freegait-zones", (ZONES_JSON,), render_zones),)),
    Experiment("crab", "Example 3 (Figs. 10-14): crab angle 0 -> 20 deg mid-walk, direction before and after",
               CrabParams, crab, (Section("freegait-crab", (CRAB_JSON,), render_crab),)),
    Experiment("circling", "Circling gait (Sec. 4.1) over a minefield, aware and unaware", TurnParams, circling,
               (Section("freegait-circling", (CIRCLING_JSON,), render_turn("circling")),)),
    Experiment("spinning", "Spinning gait (Sec. 4.2) over a minefield, aware and unaware", SpinParams, spinning,
               (Section("freegait-spinning", (SPINNING_JSON,), render_turn("spinning")),)),
    Experiment("sweep", "Beyond the paper: zone density sweep x random fields; finished share, footholds in zones, "
                        "stops, minimum SM, tracking error", SweepParams, sweep,
               (Section("freegait-sweep", (SWEEP_JSON,), render_sweep),)),
    Experiment("job", "The default job (`gaitmend run` with {\"kind\": \"freegait\"}) and the same at 8 zones/m^2: "
                      "the walk, its three controls and seven robustness re-simulations", JobParams, job,
               (Section("freegait-job", (JOB_JSON,), render_job),)),
    Experiment("noise", "Avoidance tested: the zone-aware walk with Table 1's DGPS error on its position and on the "
                        "zones' surveyed centres (and 2x, 4x), against exact knowledge and the zone-blind planner",
               NoiseParams, noise, (Section("freegait-noise", (NOISE_JSON,), render_noise),
                                    Section("freegait-summary", (NOISE_JSON,), render_noise_summary, readme=True))),
]

"""Beyond the paper: the zone-density sweep (``gaitmend reproduce freegait-sweep``) and the
avoidance tested under localisation and zone-position errors (issue 28,
``freegait-noise``); each run and its rendering from the committed JSON."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs import stats
from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.walk import WalkConfig, walk
from app.jobs.freegait.spec import target_met
from app.jobs.ledger import current_runs
from app.jobs.reporting import md_table, missing, progress_note
from app.jobs.freegait.reproduce.walks import NOISE_JSON, SWEEP_JSON, _cmd, _f, _ledger, _world


# -- beyond the paper: density sweep ----------------------------------------------------------
# (its JSON, written before issue 28, is a plain list of rows with a ``rerun`` flag, not a ledger)

class SweepParams(BaseModel):
    densities: str = Field("0,2,4,6,8", description="zone densities per m^2, comma-separated")
    fields: int = Field(20, ge=1, le=200, description="random minefields per density")
    distance_m: float = Field(2.0, gt=0.2, le=10.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    unaware: bool = Field(True, description="also run the zone-unaware planner on each field")
    out: Path | None = None
    json_out: Path | None = None


def sweep(p: SweepParams, log: Callable[[str], None]) -> str:
    dens = [float(x) for x in p.densities.split(",") if x.strip()]
    route = Route(distance=p.distance_m)
    rows = []
    t0 = time.perf_counter()
    partial = p.json_out.with_suffix(".partial.jsonl") if p.json_out else None
    if partial:
        partial.parent.mkdir(parents=True, exist_ok=True)
        partial.write_text("")
    # field-major, so that a partial sweep covers every density evenly
    for f in range(p.fields):
        for d in dens:
            ter, fld = _world(p.distance_m + 2.5, 3.0, p.roughness_m, 1000 + f, d, 2000 + f)
            for aware in ((True, False) if p.unaware else (True,)):
                cfg = WalkConfig(route=route, aware=aware, seed=f)
                s = walk(ter, fld, cfg).summary()
                rows.append({"density": d, "field": f, "aware": aware, **{k: s[k] for k in (
                    "outcome", "finished", "footholds", "footholds_in_zones", "stop_time_s", "min_sm_m",
                    "tracking_error_max_m", "tracking_error_final_m", "mean_speed_m_s", "failed_touchdowns")},
                    "target_met": target_met(s, cfg.params.sm_min)})
                if partial:
                    with partial.open("a") as fh:
                        fh.write(json.dumps(rows[-1], default=float) + "\n")
            log(f"density {d:g} field {f}: {rows[-1]['outcome']}  ({time.perf_counter() - t0:.0f} s)")
    return _write(p, sweep_markdown(rows, dens, p), rows)


def _write(p, md: str, rows) -> str:
    if getattr(p, "out", None):
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(md + "\n")
    if getattr(p, "json_out", None):
        p.json_out.parent.mkdir(parents=True, exist_ok=True)
        p.json_out.write_text(json.dumps(rows, indent=1, default=float))
    return md


def sweep_markdown(rows: list[dict], dens: list[float], p: SweepParams) -> str:
    fields = len({r["field"] for r in rows})
    md = [f"{fields} random minefields per density (terrain and zones from seeds 1000+i / 2000+i), {p.distance_m} m "
          f"straight route at 0.02 m/s, ground {p.roughness_m} m:", "",
          "| zones/m^2 | planner | finished | footholds in zones (total) | runs with a foothold in a zone | body stopped (s, mean) "
          "| min SM (m, worst) | tracking error max (m, mean / worst) | mean speed (m/s) |", "|---|---|---|---|---|---|---|---|---|"]
    for d in dens:
        for aware in ((True, False) if p.unaware else (True,)):
            rs = [r for r in rows if r["density"] == d and r["aware"] == aware]
            if not rs:
                continue
            md.append(f"| {d:g} | {'aware' if aware else 'unaware'} | {sum(r['finished'] for r in rs)}/{len(rs)} | "
                      f"{sum(r['footholds_in_zones'] for r in rs)} | {sum(r['footholds_in_zones'] > 0 for r in rs)}/{len(rs)} | "
                      f"{np.mean([r['stop_time_s'] for r in rs]):.1f} | {min(r['min_sm_m'] for r in rs):.3f} | "
                      f"{np.mean([r['tracking_error_max_m'] for r in rs]):.3f} / {max(r['tracking_error_max_m'] for r in rs):.3f} | "
                      f"{np.mean([r['mean_speed_m_s'] for r in rs]):.4f} |")
    fails = [r for r in rows if r["aware"] and not r["finished"]]
    if fails:
        md += ["", "Aware runs that did not finish: " + ", ".join(f"{r['density']:g}/m^2 field {r['field']} ({r['outcome']})"
                                                                 for r in fails)]
    return "\n".join(md)


def render_sweep(datas: list) -> str:
    rows = datas[0]
    if not rows:
        return missing(SWEEP_JSON, "gaitmend reproduce freegait-sweep --json-out docs/freegait_sweep.json")
    dens = sorted({r["density"] for r in rows})
    aw, un = [r for r in rows if r["aware"]], [r for r in rows if not r["aware"]]
    hit_un = [r for r in un if r["footholds_in_zones"] > 0]
    top = max(dens)
    un_top = [r for r in un if r["density"] == top]
    return (sweep_markdown(rows, dens, SweepParams()) + "\n\n"
            f"{len(rows)} walks ({len(dens)} densities x {len({r['field'] for r in rows})} fields x 2 planners); "
            f"{sum(r['finished'] for r in rows)} ran to the end. The zone-aware planner finished "
            f"{sum(r['finished'] for r in aw)} of its {len(aw)} routes with **{sum(r['footholds_in_zones'] for r in aw)} "
            f"footholds in zones out of {sum(r['footholds'] for r in aw)}** (runs with none: "
            f"{stats.rate_text(stats.success_rate(sum(r['footholds_in_zones'] == 0 for r in aw), len(aw)))}); on the same "
            f"fields the zone-blind planner stepped into {sum(r['footholds_in_zones'] for r in un)} zones in "
            f"{stats.rate_text(stats.success_rate(len(hit_un), len(un)))} of its runs ({sum(r['footholds_in_zones'] for r in un_top)} "
            f"in {sum(r['footholds_in_zones'] > 0 for r in un_top)} of {len(un_top)} runs at {top:g}/m^2). Body stops of the "
            f"aware planner: at most {max(r['stop_time_s'] for r in aw):.1f} s in one run. Rows re-run with later code "
            f"(`rerun`): {sum(bool(r.get('rerun')) for r in rows)}.\n")


# -- issue 28: avoidance under localisation and zone-position errors ----------------------------

DGPS_SIGMA_M = 0.01  # Table 1: DGPS accuracy +-0.02 m, taken as two standard deviations per axis
NOISE_ARMS = {"exact": (True, 0.0), "dgps": (True, 1.0), "dgps_x2": (True, 2.0), "dgps_x4": (True, 4.0),
              "unaware": (False, 0.0)}


class NoiseParams(BaseModel):
    density_per_m2: float = Field(8.0, ge=0.0, le=20.0, description="zones per m^2 (8: the sweep's densest)")
    fields: int = Field(10, ge=1, le=100, description="random minefields (the sweep's seeds 1000+i / 2000+i)")
    arms: str = Field("exact,dgps,dgps_x2,dgps_x4,unaware", description="of " + ", ".join(NOISE_ARMS) + " (dgps: position and "
                      "zone errors of Table 1's DGPS, sigma 0.01 m per axis; _x2, _x4 twice, four times that)")
    distance_m: float = Field(2.0, gt=0.2, le=10.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    json_out: Path | None = Field(Path(NOISE_JSON), description="the ledger: one run per field and arm")


NOISE_KEYS = ("finished", "outcome", "footholds", "footholds_in_zones", "footholds_in_safe_areas", "closest_zone_m",
              "min_sm_m", "foothold_error_max_m", "stop_time_s", "tracking_error_max_m")


def _noise_walk(p: NoiseParams, arm: str, f: int) -> dict:
    aware, scale = NOISE_ARMS[arm]
    ter, fld = _world(p.distance_m + 2.5, 3.0, p.roughness_m, 1000 + f, p.density_per_m2, 2000 + f)
    cfg = WalkConfig(route=Route(distance=p.distance_m), aware=aware, seed=f, position_error_m=scale * DGPS_SIGMA_M,
                     zone_error_m=scale * DGPS_SIGMA_M)
    s = walk(ter, fld, cfg).summary()
    return {k: s[k] for k in NOISE_KEYS} | {"zones": len(fld.centres), "sigma_m": scale * DGPS_SIGMA_M}


def noise(p: NoiseParams, log: Callable[[str], None]) -> str:
    arms = [a.strip() for a in p.arms.split(",") if a.strip()]
    bad = [a for a in arms if a not in NOISE_ARMS]
    if bad:
        raise ValueError(f"--arms: unknown {bad}; known: {list(NOISE_ARMS)}")
    led = _ledger(p, "noise", p.fields * len(arms))
    base = p.model_dump(mode="json", exclude={"json_out", "fields", "arms"})
    for f in range(p.fields):  # field-major: a partial run covers every arm evenly
        for arm in arms:
            led.run(f"{arm} field {f}", base | {"arm": arm, "field": f, "sigma_m": NOISE_ARMS[arm][1] * DGPS_SIGMA_M},
                    f, lambda arm=arm, f=f: _noise_walk(p, arm, f), log)
    return render_noise([led.data])


def _noise_arms(data: dict) -> dict[str, dict[int, dict]]:
    out: dict[str, dict[int, dict]] = {}
    for r in current_runs(data):
        out.setdefault(r["spec"]["arm"], {})[r["spec"]["field"]] = r["result"]
    return out


def render_noise(datas: list) -> str:
    data = datas[0]
    arms = _noise_arms(data) if data else {}
    if not arms:
        return missing(NOISE_JSON, _cmd("noise"))
    p, rows = data["params"], []
    for arm in (a for a in NOISE_ARMS if a in arms):
        rs = list(arms[arm].values())
        close = [r["closest_zone_m"] for r in rs if r["closest_zone_m"] is not None]
        rows.append([arm, f"{rs[0]['sigma_m']:.2f}", f"{sum(r['finished'] for r in rs)}/{len(rs)}",
                     f"{sum(r['footholds_in_zones'] for r in rs)} / {sum(r['footholds'] for r in rs)}",
                     stats.rate_text(stats.success_rate(sum(r["footholds_in_zones"] > 0 for r in rs), len(rs))),
                     sum(r["footholds_in_safe_areas"] for r in rs), _f(min(close, default=None)),
                     _f(float(np.mean(close)) if close else None), _f(max(r["foothold_error_max_m"] for r in rs))])
    out = [f"{p['density_per_m2']:g} zones/m^2 (zone 0.05 m, safe area 0.15 m: 0.05 m of clearance around a zone), "
           f"{p['distance_m']} m straight route, ground {p['roughness_m']} m, the sweep's fields (seeds 1000+i / 2000+i); "
           "sigma is the standard deviation per axis of both the believed position (Gauss-Markov, 60 s) and each "
           "zone's surveyed centre; footholds are counted against the true zones:\n",
           md_table(["arm", "sigma (m)", "finished", "footholds in zones / all", "runs with a foothold in a zone "
                     "(Clopper-Pearson 95 %)", "in safe areas", "closest foot centre to a zone centre (m): worst",
                     "mean of each run's closest", "touchdown vs believed plan, worst (m)"], rows)]
    for arm in (a for a in NOISE_ARMS if a in arms and a != "exact"):
        common = sorted(set(arms[arm]) & set(arms.get("exact", {})))
        if len(common) >= 2:
            a = [arms[arm][f]["footholds_in_zones"] for f in common]
            b = [arms["exact"][f]["footholds_in_zones"] for f in common]
            out.append(f"- {arm} against exact, footholds in zones per field (lower is better): "
                       + stats.paired_text(stats.paired(a, b, higher_is_better=False, names=(arm, "exact")), digits=2))
            ca = [arms[arm][f]["closest_zone_m"] for f in common]
            cb = [arms["exact"][f]["closest_zone_m"] for f in common]
            if None not in ca and None not in cb:
                out.append(f"- {arm} against exact, each run's closest foot centre to a zone centre (higher is better): "
                           + stats.paired_text(stats.paired(ca, cb, names=(arm, "exact")), "m", digits=3))
    out += ["", stats.PAIRED_NOTE, progress_note(data, len(current_runs(data)))]
    return "\n".join(out) + "\n"


def render_noise_summary(datas: list) -> str:
    data = datas[0]
    arms = _noise_arms(data) if data else {}
    if "dgps" not in arms:
        return ""
    rs = list(arms["dgps"].values())
    k = sum(r["footholds_in_zones"] > 0 for r in rs)
    ci = stats.success_rate(k, len(rs))["ci"]
    sigma = rs[0].get("sigma_m", DGPS_SIGMA_M)
    w = stats.wilson(k, len(rs))
    if "dgps_x2" in arms:  # Table 1's +-0.02 m read as one standard deviation
        r2 = list(arms["dgps_x2"].values())
        k2 = sum(r["footholds_in_zones"] > 0 for r in r2)
        c2 = stats.success_rate(k2, len(r2))["ci"]
        one_sd = (f"; read as one standard deviation (sigma {r2[0].get('sigma_m', 2 * DGPS_SIGMA_M):g} m) in {k2} of "
                  f"{len(r2)} (Clopper-Pearson {c2[0]:.2f}-{c2[1]:.2f})")
    else:
        one_sd, r2 = "", None
    return (f"- **freegait** (paper 004): with position and zone errors of sigma {sigma:g} m per axis (Table 1's "
            f"DGPS +-0.02 m read as two standard deviations"
            + ("" if r2 else "; the sigma 0.02 m reading is not run yet") + ") the zone-aware "
            f"walk stepped into a zone in {k} of {len(rs)} runs at {data['params']['density_per_m2']:g} zones/m^2: "
            f"a true rate up to {100 * ci[1]:.0f} % is still possible (95 % Clopper-Pearson {ci[0]:.2f}-{ci[1]:.2f}; "
            f"Wilson {w[0]:.2f}-{w[1]:.2f}){one_sd} ([docs/freegait.md](docs/freegait.md)).\n")

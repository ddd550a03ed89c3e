"""The paper's three simulation examples (Sec. 5.1), circling and spinning runs, and the
density sweep beyond the paper: ``gaitmend reproduce freegait`` (k_ev, the first),
``freegait-zones``, ``freegait-crab``, ``freegait-circling``, ``freegait-spinning``,
``freegait-sweep``. Each returns markdown and, with ``json_out``, the raw rows; the
numbers in docs/freegait.md come from these commands."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.base import BenchEntry, Experiment
from app.jobs.freegait.planner.geometry import Motion, kinematic_margin
from app.jobs.freegait.planner.params import GaitParams, nominal_re, r1
from app.jobs.freegait.planner.route import Change, Route
from app.jobs.freegait.planner.search import SearchInput, candidate_grid, search
from app.jobs.freegait.planner.walk import WalkConfig, stand_pose, walk
from app.jobs.freegait.spec import target_met
from app.robots.silo6 import SILO6, TRIPODS
from app.jobs.freegait.terrain import Minefield, make_minefield, make_terrain

KEVS = (0.0, 0.02, 0.04, 0.06, 0.08, 0.1)


def _world(length: float, width: float, roughness: float, t_seed: int, density: float, f_seed: int):
    ter = make_terrain((-1.0, length - 1.0), (-width / 2, width / 2), roughness, t_seed)
    _, feet = stand_pose(SILO6, ter)
    return ter, make_minefield(ter, density, 0.05, 0.15, f_seed, cleared=feet[:, :2])


def _write(p, md: str, rows) -> str:
    if getattr(p, "out", None):
        p.out.parent.mkdir(parents=True, exist_ok=True)
        p.out.write_text(md + "\n")
    if getattr(p, "json_out", None):
        p.json_out.parent.mkdir(parents=True, exist_ok=True)
        p.json_out.write_text(json.dumps(rows, indent=1, default=float))
    return md


def _f(v, fmt="{:.3f}"):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v)


# -- example 1: k_ev --------------------------------------------------------------------------

class KevParams(BaseModel):
    step_s: float = Field(30.0, ge=5.0, le=120.0, description="k_ev is raised every step_s seconds (the paper: 30 s)")
    speed_m_s: float = Field(0.02, gt=0.0, le=0.03)
    seeds: int = Field(3, ge=1, le=20, description="terrain seeds of the constant-k_ev runs")
    constant_m: float = Field(1.5, gt=0.2, le=5.0, description="route length of each constant-k_ev run")
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    extra_kevs: str = Field("1,5", description="k_ev values beyond the paper's range for the constant runs")
    out: Path | None = None
    json_out: Path | None = None


def _phase_stats(r, t0: float, t1: float) -> dict:
    tr = [x for x in r.transfers if t0 <= x["t_lift"] < t1]
    sup = [x["support_s"] for x in tr if x.get("support_s") is not None]
    s = r.steps
    w = (s["t"] >= t0) & (s["t"] < t1) & (s["t"] > 0)
    return {"transfers": len(tr), "support_s": float(np.mean(sup)) if sup else float("nan"),
            "transfer_s": float(np.mean([x["transfer_s"] for x in tr])) if tr else float("nan"),
            "mean_sm_m": float(np.nanmean(s["sm"][w])) if w.any() else float("nan"),
            "min_sm_m": float(np.nanmin(s["sm"][w])) if w.any() else float("nan"),
            "min_k_r_m": float(np.nanmin(s["k_r"][w])) if w.any() else float("nan"),
            "stop_s": float((s["stop"][w] > 0).sum() * 0.1), "sm_t": float(np.mean([x["sm_t"] for x in tr if "sm_t" in x] or [np.nan]))}


def kev(p: KevParams, log: Callable[[str], None]) -> str:
    dur = p.step_s * len(KEVS)
    dist = p.speed_m_s * dur
    ter, fld = _world(dist + 2.5, 3.0, p.roughness_m, 0, 0.0, 0)
    route = Route(speed=p.speed_m_s, distance=dist,
                  changes=tuple(Change(p.step_s * i, k_ev=k) for i, k in enumerate(KEVS)))
    log(f"stepped k_ev walk: {dist:.2f} m")
    r = walk(ter, fld, WalkConfig(route=route, params=GaitParams(k_ev=KEVS[0])))
    stepped = [{"k_ev": k, **_phase_stats(r, p.step_s * i, p.step_s * (i + 1))} for i, k in enumerate(KEVS)]
    const = []
    extra = [float(x) for x in p.extra_kevs.split(",") if x.strip()]
    for k in (*KEVS, *extra):
        acc = []
        for seed in range(p.seeds):
            log(f"constant k_ev {k} seed {seed}")
            ter_c, fld_c = _world(p.constant_m + 2.5, 3.0, p.roughness_m, seed, 0.0, 0)
            rc = walk(ter_c, fld_c, WalkConfig(route=Route(speed=p.speed_m_s, distance=p.constant_m),
                                              params=GaitParams(k_ev=k)))
            st = _phase_stats(rc, 0.0, 1e9)
            st.update(mean_speed=rc.summary()["mean_speed_m_s"], finished=rc.outcome == "finished")
            acc.append(st)
        const.append({"k_ev": k, **{key: float(np.nanmean([a[key] for a in acc])) for key in acc[0]}})
    md = [f"Stepped k_ev (the paper's protocol: one walk, k_ev raised every {p.step_s:g} s, {p.speed_m_s} m/s, "
          f"ground {p.roughness_m} m, outcome {r.outcome}):", "",
          "| k_ev | transfers | support (s) | transfer (s) | mean SM (m) | min SM (m) | min K_R (m) | SM_t chosen (m) | stopped (s) |",
          "|---|---|---|---|---|---|---|---|---|"]
    for s in stepped:
        md.append(f"| {s['k_ev']:g} | {s['transfers']} | {_f(s['support_s'], '{:.2f}')} | {_f(s['transfer_s'], '{:.2f}')} | "
                  f"{_f(s['mean_sm_m'])} | {_f(s['min_sm_m'])} | {_f(s['min_k_r_m'])} | {_f(s['sm_t'])} | {s['stop_s']:.1f} |")
    md += ["", f"Constant k_ev, one walk of {p.constant_m} m per k_ev on each of {p.seeds} terrain seeds (means; "
               f"k_ev above 0.1 is beyond the paper's range):", "",
           "| k_ev | transfers | support (s) | transfer (s) | mean SM (m) | min SM (m) | min K_R (m) | SM_t chosen (m) | mean speed (m/s) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for s in const:
        md.append(f"| {s['k_ev']:g} | {s['transfers']:.1f} | {_f(s['support_s'], '{:.2f}')} | {_f(s['transfer_s'], '{:.2f}')} | "
                  f"{_f(s['mean_sm_m'])} | {_f(s['min_sm_m'])} | {_f(s['min_k_r_m'])} | {_f(s['sm_t'])} | {_f(s['mean_speed'], '{:.4f}')} |")
    return _write(p, "\n".join(md), {"stepped": stepped, "constant": const})


# -- example 2: zones, aware vs unaware -------------------------------------------------------

class ZonesParams(BaseModel):
    density_per_m2: float = Field(3.0, ge=0.0, le=20.0)
    fields: int = Field(10, ge=1, le=100, description="random minefields (seeds 0..fields-1)")
    distance_m: float = Field(2.0, gt=0.2, le=10.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    out: Path | None = None
    json_out: Path | None = None


def _pair(ter, fld, route, seed):
    out = {}
    for aware in (True, False):
        s = walk(ter, fld, WalkConfig(route=route, aware=aware, seed=seed)).summary()
        out["aware" if aware else "unaware"] = s
    return out


def zones(p: ZonesParams, log: Callable[[str], None]) -> str:
    rows = []
    route = Route(distance=p.distance_m)
    for seed in range(p.fields):
        log(f"field {seed}")
        ter, fld = _world(p.distance_m + 2.5, 3.0, p.roughness_m, seed, p.density_per_m2, seed)
        r = _pair(ter, fld, route, seed)
        rows.append({"field": seed, "zones": len(fld.centres), **{f"{k}_{m}": r[k][m] for k in r for m in (
            "footholds", "footholds_in_zones", "footholds_in_safe_areas", "finished", "stop_time_s", "min_sm_m")}})
    md = [f"{p.fields} random minefields of {p.density_per_m2:g} zones/m^2 (zone 0.05 m, safe area 0.15 m), "
          f"{p.distance_m} m straight route, ground {p.roughness_m} m; the same field for both planners:", "",
          "| field | zones | aware: footholds / in zones / in safe areas / finished | unaware: footholds / in zones / in safe areas / finished |",
          "|---|---|---|---|"]
    for r in rows:
        md.append(f"| {r['field']} | {r['zones']} | {r['aware_footholds']} / **{r['aware_footholds_in_zones']}** / "
                  f"{r['aware_footholds_in_safe_areas']} / {r['aware_finished']} | {r['unaware_footholds']} / "
                  f"**{r['unaware_footholds_in_zones']}** / {r['unaware_footholds_in_safe_areas']} / {r['unaware_finished']} |")
    tot = {k: sum(r[k] for r in rows) for k in ("aware_footholds", "aware_footholds_in_zones", "unaware_footholds",
                                                "unaware_footholds_in_zones", "unaware_footholds_in_safe_areas")}
    md += ["", f"Total: aware {tot['aware_footholds_in_zones']} of {tot['aware_footholds']} footholds in zones; unaware "
               f"{tot['unaware_footholds_in_zones']} of {tot['unaware_footholds']} in zones "
               f"({tot['unaware_footholds_in_safe_areas']} in safe areas)."]
    return _write(p, "\n".join(md), rows)


# -- example 3: crab angle 0 -> 20 deg --------------------------------------------------------

class CrabParams(BaseModel):
    change_at_s: float = Field(18.0, ge=1.0, le=200.0, description="18 s falls inside a transfer of tripod 2, as in Fig. 11")
    to_deg: float = Field(20.0, ge=-45.0, le=45.0)
    distance_m: float = Field(1.2, gt=0.2, le=5.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    out: Path | None = None
    json_out: Path | None = None
    figure: Path | None = Field(None, description="write the five states' footholds in the body frame (SVG/PNG stem)")


def _direction(pos: np.ndarray, t: np.ndarray, t0: float, t1: float) -> float:
    w = (t >= t0) & (t <= t1)
    if w.sum() < 2:
        return float("nan")
    d = pos[w][-1, :2] - pos[w][0, :2]
    return math.degrees(math.atan2(d[1], d[0]))


def crab(p: CrabParams, log: Callable[[str], None]) -> str:
    ter, fld = _world(p.distance_m + 2.5, 4.0, p.roughness_m, 0, 0.0, 0)
    route = Route(distance=p.distance_m, changes=(Change(p.change_at_s, crab_angle_deg=p.to_deg),))
    r = walk(ter, fld, WalkConfig(route=route))
    s = r.steps
    t = s["t"]
    applied = t[np.flatnonzero(np.abs(s["crab_deg"] - p.to_deg) < 1e-9)]
    t_applied = float(applied[0]) if len(applied) else float("nan")
    before = _direction(s["pos"], t, 2.0, p.change_at_s)
    after = _direction(s["pos"], t, t_applied + 2.0, t[-1]) if math.isfinite(t_applied) else float("nan")
    # the five states of Figs. 10-14 around the change
    trs = r.transfers
    during = next((x for x in trs if x["t_lift"] <= p.change_at_s <= x.get("t_touchdown", 1e9)), None)
    nxt = [x for x in trs if x["t_lift"] > p.change_at_s]
    rows = [{"transfer": i + 1, "tripod": x["tripod"], "t_lift": x["t_lift"], "t_search": x["t_search"],
             "t_touchdown": x.get("t_touchdown"), "crab_deg_at_search": float(s["crab_deg"][int(round(x["t_search"] / 0.1))])}
            for i, x in enumerate(trs)]
    md = [f"Crab angle commanded 0 -> {p.to_deg:g} deg at {p.change_at_s:g} s (ground {p.roughness_m} m, no zones, "
          f"outcome {r.outcome}):", "",
          f"- the new angle took effect at {t_applied:.1f} s, when the transfer in progress at the command had ended "
          f"(tripod {during['tripod'] if during else '-'}, {during['t_lift'] if during else '-'} -> "
          f"{during.get('t_touchdown') if during else '-'} s), as in Figs. 11-12",
          f"- realised direction of travel (world): {before:.1f} deg before, {after:.1f} deg after (commanded 0 and {p.to_deg:g})",
          f"- body-frame heading drift over the walk: {math.degrees(s['rpy'][-1][2]):.2f} deg", "",
          "| transfer | tripod | lift (s) | search (s) | touchdown (s) | crab angle used (deg) |", "|---|---|---|---|---|---|"]
    for x in rows:
        md.append(f"| {x['transfer']} | {x['tripod']} | {x['t_lift']:.1f} | {x['t_search']:.1f} | "
                  f"{_f(x['t_touchdown'], '{:.1f}')} | {x['crab_deg_at_search']:.0f} |")
    if p.figure:
        _crab_figure(r, p.change_at_s, during, nxt, p.figure)
    return _write(p, "\n".join(md), {"applied_s": t_applied, "direction_before_deg": before, "direction_after_deg": after,
                                     "transfers": rows})


def _crab_figure(r, t_change, during, nxt, stem: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from app.core.plots import _save

    s = r.steps
    t = s["t"]
    # state windows: 1 all in support before, 2 the transfer in progress, 3 its last second, 4 support after, 5 next transfer
    if during is None or not nxt:
        return
    td = during.get("t_touchdown", t[-1])
    n1 = nxt[0]
    wins = [(max(0.0, during["t_lift"] - 3.0), during["t_lift"]), (during["t_lift"], t_change + 0.5),
            (t_change + 0.5, td), (td, n1["t_lift"]), (n1["t_lift"], n1.get("t_touchdown", t[-1]))]
    fig, axes = plt.subplots(1, 5, figsize=(16, 3.6), sharey=True)
    feet_b = []
    for k in range(len(t)):
        yaw = s["rpy"][k][2]
        c, sn = math.cos(yaw), math.sin(yaw)
        d = s["tips"][k][:, :2] - s["pos"][k][:2]
        feet_b.append(np.stack([c * d[:, 0] + sn * d[:, 1], -sn * d[:, 0] + c * d[:, 1]], -1))
    feet_b = np.array(feet_b)
    for i, (ax, (a, b)) in enumerate(zip(axes, wins)):
        w = (t >= a) & (t <= b)
        for rect in SILO6.workspaces():
            ax.add_patch(plt.Rectangle((rect[0], rect[2]), rect[1] - rect[0], rect[3] - rect[2], fill=False, ls="--", lw=0.8))
        for leg in range(6):
            sup = s["phase"][w][:, leg] == 0
            pts = feet_b[w][:, leg]
            ax.scatter(pts[sup, 0], pts[sup, 1], s=10, color="0.35" if leg in (0, 3, 4) else "0.6")
            ax.scatter(pts[~sup, 0], pts[~sup, 1], s=3, color="k" if leg in (0, 3, 4) else "0.8")
        ax.set_title(f"state {i + 1}: {a:.1f}-{b:.1f} s", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("x body (m)")
    axes[0].set_ylabel("y body (m)")
    _save(fig, stem.parent, stem.name)


# -- circling and spinning --------------------------------------------------------------------

class TurnParams(BaseModel):
    turn_rate_deg_s: float = Field(0.5, ge=-5.0, le=5.0)
    speed_m_s: float = Field(0.015, ge=0.0, le=0.03)
    distance_m: float = Field(1.0, gt=0.1, le=5.0)
    turn_deg: float = Field(90.0, gt=0.0, le=360.0)
    density_per_m2: float = Field(3.0, ge=0.0, le=20.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    out: Path | None = None
    json_out: Path | None = None


def _turn(p: TurnParams, gait: str, log) -> str:
    ter, fld = _world(5.0, 5.0, p.roughness_m, 0, p.density_per_m2, 0)
    route = Route(gait=gait, speed=p.speed_m_s if gait == "circling" else 0.0, distance=p.distance_m,
                  turn_rate_deg_s=p.turn_rate_deg_s, turn_deg=p.turn_deg)
    rows = {}
    for aware in (True, False):
        r = walk(ter, fld, WalkConfig(route=route, aware=aware))
        s = r.summary()
        pos = r.steps["pos"]
        yaw = math.degrees(r.steps["rpy"][-1][2] - r.steps["rpy"][0][2])
        rows["aware" if aware else "unaware"] = {**{k: s[k] for k in ("outcome", "time_s", "transfers", "footholds",
                                                                        "footholds_in_zones", "min_sm_m", "min_k_r_m",
                                                                        "stop_time_s", "tracking_error_max_m")},
                                                 "yaw_deg": yaw, "end_xy": pos[-1, :2].tolist()}
    a = rows["aware"]
    if gait == "circling":
        radius = p.speed_m_s / math.radians(abs(p.turn_rate_deg_s))
        head = (f"Circling: {p.speed_m_s} m/s at {p.turn_rate_deg_s:g} deg/s (radius {radius:.2f} m) for {p.distance_m} m, "
                f"{p.density_per_m2:g} zones/m^2, ground {p.roughness_m} m")
        expect = math.degrees(p.distance_m / radius)
    else:
        head = f"Spinning: {p.turn_rate_deg_s:g} deg/s to {p.turn_deg:g} deg, {p.density_per_m2:g} zones/m^2, ground {p.roughness_m} m"
        expect = p.turn_deg
    md = [head + ":", "", "| planner | outcome | time (s) | yaw turned (deg; commanded) | end (x, y) m | transfers | "
          "in zones | min SM (m) | min K_R | stopped (s) | track err (m) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, v in rows.items():
        md.append(f"| {k} | {v['outcome']} | {v['time_s']:.1f} | {v['yaw_deg']:.1f} ({expect:.1f}) | "
                  f"({v['end_xy'][0]:.2f}, {v['end_xy'][1]:.2f}) | {v['transfers']} | {v['footholds_in_zones']} | "
                  f"{_f(v['min_sm_m'])} | {_f(v['min_k_r_m'])} | {v['stop_time_s']:.1f} | {_f(v['tracking_error_max_m'])} |")
    del a
    return _write(p, "\n".join(md), rows)


def circling(p: TurnParams, log) -> str:
    return _turn(p, "circling", log)


class SpinParams(TurnParams):
    turn_rate_deg_s: float = Field(2.0, ge=-5.0, le=5.0)
    speed_m_s: float = Field(0.0, ge=0.0, le=0.0)


def spinning(p: SpinParams, log) -> str:
    return _turn(p, "spinning", log)


# -- beyond the paper: density sweep ----------------------------------------------------------

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


EXPERIMENTS = [
    Experiment("kev", "Example 1 (Fig. 8): k_ev in 0..0.1 stepped every 30 s; phase durations, SM and K_R per k_ev",
               KevParams, kev),
    Experiment("zones", "Example 2 (Fig. 9): random forbidden zones, planner aware vs unaware on the same fields",
               ZonesParams, zones),
    Experiment("crab", "Example 3 (Figs. 10-14): crab angle 0 -> 20 deg mid-walk, direction before and after",
               CrabParams, crab),
    Experiment("circling", "Circling gait (Sec. 4.1) over a minefield, aware and unaware", TurnParams, circling),
    Experiment("spinning", "Spinning gait (Sec. 4.2) over a minefield, aware and unaware", SpinParams, spinning),
    Experiment("sweep", "Beyond the paper: zone density sweep x random fields; finished share, footholds in zones, "
                        "stops, minimum SM, tracking error", SweepParams, sweep),
]


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

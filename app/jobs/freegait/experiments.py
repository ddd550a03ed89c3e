"""The paper's three simulation examples (Sec. 5.1), circling and spinning runs, the density
sweep beyond the paper, and the walk under localisation and zone-position errors (issue
28): ``gaitmend reproduce freegait`` (k_ev, the first), ``freegait-zones``,
``freegait-crab``, ``freegait-circling``, ``freegait-spinning``, ``freegait-sweep``,
``freegait-noise``. Each appends its finished runs to its JSON under docs/ (a re-run skips
them: ``--write-docs``) and docs/freegait.md's generated sections are rendered from those
files alone."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs import stats
from app.jobs.base import BenchEntry, Experiment
from app.jobs.freegait.planner.geometry import Motion, kinematic_margin
from app.jobs.freegait.planner.params import GaitParams, nominal_re, r1
from app.jobs.freegait.planner.route import Change, Route
from app.jobs.freegait.planner.search import SearchInput, candidate_grid, search
from app.jobs.freegait.planner.walk import WalkConfig, stand_pose, walk
from app.jobs.freegait.spec import target_met
from app.jobs.ledger import Ledger, current_runs, results_by_name
from app.jobs.evidence import controls_of, robustness_of
from app.jobs.reporting import Section, md_table, missing, progress_note, yes
from app.robots.silo6 import SILO6, TRIPODS
from app.jobs.freegait.terrain import Minefield, make_minefield, make_terrain

KEVS = (0.0, 0.02, 0.04, 0.06, 0.08, 0.1)
SCIENCE = ("app/jobs/freegait/planner", "app/jobs/freegait/terrain.py", "app/robots/silo6.py")
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


# -- example 1: k_ev --------------------------------------------------------------------------

class KevParams(BaseModel):
    step_s: float = Field(30.0, ge=5.0, le=120.0, description="k_ev is raised every step_s seconds (the paper: 30 s)")
    speed_m_s: float = Field(0.02, gt=0.0, le=0.03)
    seeds: int = Field(3, ge=1, le=20, description="terrain seeds of the constant-k_ev runs")
    constant_m: float = Field(1.5, gt=0.2, le=5.0, description="route length of each constant-k_ev run")
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    extra_kevs: str = Field("1,5", description="k_ev values beyond the paper's range for the constant runs")
    json_out: Path | None = Field(Path(KEV_JSON), description="the ledger (resumable)")


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


def _stepped(p: KevParams) -> dict:
    dist = p.speed_m_s * p.step_s * len(KEVS)
    ter, fld = _world(dist + 2.5, 3.0, p.roughness_m, 0, 0.0, 0)
    route = Route(speed=p.speed_m_s, distance=dist, changes=tuple(Change(p.step_s * i, k_ev=k) for i, k in enumerate(KEVS)))
    r = walk(ter, fld, WalkConfig(route=route, params=GaitParams(k_ev=KEVS[0])))
    return {"outcome": r.outcome, "rows": [{"k_ev": k, **_phase_stats(r, p.step_s * i, p.step_s * (i + 1))}
                                           for i, k in enumerate(KEVS)]}


def _constant(p: KevParams, k: float) -> dict:
    acc = []
    for seed in range(p.seeds):
        ter, fld = _world(p.constant_m + 2.5, 3.0, p.roughness_m, seed, 0.0, 0)
        rc = walk(ter, fld, WalkConfig(route=Route(speed=p.speed_m_s, distance=p.constant_m), params=GaitParams(k_ev=k)))
        acc.append(_phase_stats(rc, 0.0, 1e9) | {"mean_speed": rc.summary()["mean_speed_m_s"],
                                                   "finished": rc.outcome == "finished"})
    return {"k_ev": k, "seeds": acc}


def kev(p: KevParams, log: Callable[[str], None]) -> str:
    kevs = [*KEVS, *(float(x) for x in p.extra_kevs.split(",") if x.strip())]
    led = _ledger(p, "kev", 1 + len(kevs))
    led.run("stepped", {"what": "stepped"} | p.model_dump(mode="json", exclude={"json_out"}), 0,
            lambda: _stepped(p), log)
    for k in kevs:
        led.run(f"constant {k:g}", {"what": "constant", "k_ev": k} | p.model_dump(mode="json", exclude={"json_out"}),
                0, lambda k=k: _constant(p, k), log)
    return render_kev([led.data])


_KEV_COLS = ["k_ev", "transfers", "support (s)", "transfer (s)", "mean SM (m)", "min SM (m)", "min K_R (m)", "SM_t chosen (m)"]


def _kev_cells(s: dict, transfers: str) -> list[str]:
    return [f"{s['k_ev']:g}", transfers, _f(s["support_s"], "{:.2f}"), _f(s["transfer_s"], "{:.2f}"), _f(s["mean_sm_m"]),
            _f(s["min_sm_m"]), _f(s["min_k_r_m"]), _f(s["sm_t"])]


def render_kev(datas: list) -> str:
    data, res = _first(datas)
    if not res:
        return missing(KEV_JSON, _cmd("kev"))
    p, out = data["params"], []
    if "stepped" in res:
        st = res["stepped"]
        out += [f"Stepped k_ev (the paper's protocol: one walk, k_ev raised every {p['step_s']:g} s, {p['speed_m_s']} m/s, "
                f"ground {p['roughness_m']} m, outcome {st['outcome']}):", "",
                md_table(_KEV_COLS + ["stopped (s)"], [_kev_cells(s, str(s["transfers"])) + [f"{s['stop_s']:.1f}"]
                                                       for s in st["rows"]])]
    const = sorted((v for k, v in res.items() if k.startswith("constant")), key=lambda v: v["k_ev"])
    rows = []
    for c in const:
        mean = {key: float(np.nanmean([np.nan if a[key] is None else a[key] for a in c["seeds"]]))
                for key in c["seeds"][0] if key != "finished"}
        rows.append(_kev_cells(mean | {"k_ev": c["k_ev"]}, f"{mean['transfers']:.1f}") + [_f(mean["mean_speed"], "{:.4f}")])
    if rows:
        out += [f"Constant k_ev, one walk of {p['constant_m']} m per k_ev on each of {p['seeds']} terrain seeds (means; "
                "k_ev above 0.1 is beyond the paper's range):", "", md_table(_KEV_COLS + ["mean speed (m/s)"], rows)]
    return "\n".join(out) + progress_note(data, len(current_runs(data)))


# -- example 2: zones, aware vs unaware -------------------------------------------------------

class ZonesParams(BaseModel):
    density_per_m2: float = Field(3.0, ge=0.0, le=20.0)
    fields: int = Field(10, ge=1, le=100, description="random minefields (seeds 0..fields-1)")
    distance_m: float = Field(2.0, gt=0.2, le=10.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    json_out: Path | None = Field(Path(ZONES_JSON), description="the ledger: one run per field")


ZONE_KEYS = ("footholds", "footholds_in_zones", "footholds_in_safe_areas", "finished", "stop_time_s", "min_sm_m",
             "closest_zone_m")


def _zone_field(p: ZonesParams, seed: int) -> dict:
    ter, fld = _world(p.distance_m + 2.5, 3.0, p.roughness_m, seed, p.density_per_m2, seed)
    out = {"field": seed, "zones": len(fld.centres)}
    for aware in (True, False):
        s = walk(ter, fld, WalkConfig(route=Route(distance=p.distance_m), aware=aware, seed=seed)).summary()
        out |= {f"{'aware' if aware else 'unaware'}_{m}": s[m] for m in ZONE_KEYS}
    return out


def zones(p: ZonesParams, log: Callable[[str], None]) -> str:
    led = _ledger(p, "zones", p.fields)
    base = p.model_dump(mode="json", exclude={"json_out", "fields"})
    for seed in range(p.fields):
        led.run(f"field {seed}", base | {"field": seed}, seed, lambda seed=seed: _zone_field(p, seed), log)
    return render_zones([led.data])


def render_zones(datas: list) -> str:
    data, res = _first(datas)
    if not res:
        return missing(ZONES_JSON, _cmd("zones"))
    p, rows = data["params"], sorted(res.values(), key=lambda r: r["field"])
    tab = [[r["field"], r["zones"]] + [f"{r[f'{k}_footholds']} / **{r[f'{k}_footholds_in_zones']}** / "
                                       f"{r[f'{k}_footholds_in_safe_areas']} / {r[f'{k}_finished']}"
                                       for k in ("aware", "unaware")] for r in rows]
    tot = {k: sum(r[k] for r in rows) for k in ("aware_footholds", "aware_footholds_in_zones", "aware_footholds_in_safe_areas",
                                                "unaware_footholds", "unaware_footholds_in_zones",
                                                "unaware_footholds_in_safe_areas")}
    hit = stats.success_rate(sum(r["unaware_footholds_in_zones"] > 0 for r in rows), len(rows))
    return (f"{len(rows)} random minefields of {p['density_per_m2']:g} zones/m^2 (zone 0.05 m, safe area 0.15 m), "
            f"{p['distance_m']} m straight route, ground {p['roughness_m']} m; the same field for both planners:\n\n"
            + md_table(["field", "zones", "aware: footholds / in zones / in safe areas / finished",
                        "unaware: footholds / in zones / in safe areas / finished"], tab)
            + f"\nTotal: aware {tot['aware_footholds_in_zones']} of {tot['aware_footholds']} footholds in zones "
              f"({tot['aware_footholds_in_safe_areas']} in safe areas); unaware {tot['unaware_footholds_in_zones']} of "
              f"{tot['unaware_footholds']} in zones ({tot['unaware_footholds_in_safe_areas']} in safe areas); runs in "
              f"which the unaware planner stepped into a zone: {stats.rate_text(hit)}.\n"
            + progress_note(data, len(rows)))


# -- example 3: crab angle 0 -> 20 deg --------------------------------------------------------

class CrabParams(BaseModel):
    change_at_s: float = Field(18.0, ge=1.0, le=200.0, description="18 s falls inside a transfer of tripod 2, as in Fig. 11")
    to_deg: float = Field(20.0, ge=-45.0, le=45.0)
    distance_m: float = Field(1.2, gt=0.2, le=5.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    json_out: Path | None = Field(Path(CRAB_JSON), description="the ledger (one run)")
    figure: Path | None = Field(None, description="write the five states' footholds in the body frame (SVG/PNG stem)")


def _direction(pos: np.ndarray, t: np.ndarray, t0: float, t1: float) -> float:
    w = (t >= t0) & (t <= t1)
    if w.sum() < 2:
        return float("nan")
    d = pos[w][-1, :2] - pos[w][0, :2]
    return math.degrees(math.atan2(d[1], d[0]))


def _crab_walk(p: CrabParams) -> dict:
    ter, fld = _world(p.distance_m + 2.5, 4.0, p.roughness_m, 0, 0.0, 0)
    r = walk(ter, fld, WalkConfig(route=Route(distance=p.distance_m, changes=(Change(p.change_at_s, crab_angle_deg=p.to_deg),))))
    s, trs = r.steps, r.transfers
    t = s["t"]
    applied = t[np.flatnonzero(np.abs(s["crab_deg"] - p.to_deg) < 1e-9)]
    t_applied = float(applied[0]) if len(applied) else float("nan")
    during = next((x for x in trs if x["t_lift"] <= p.change_at_s <= x.get("t_touchdown", 1e9)), None)
    if p.figure:
        _crab_figure(r, p.change_at_s, during, [x for x in trs if x["t_lift"] > p.change_at_s], p.figure)
    return {"outcome": r.outcome, "applied_s": t_applied, "direction_before_deg": _direction(s["pos"], t, 2.0, p.change_at_s),
            "direction_after_deg": _direction(s["pos"], t, t_applied + 2.0, t[-1]) if math.isfinite(t_applied) else None,
            "heading_drift_deg": math.degrees(s["rpy"][-1][2]),
            "during": None if during is None else {k: during.get(k) for k in ("tripod", "t_lift", "t_touchdown")},
            "transfers": [{"transfer": i + 1, "tripod": x["tripod"], "t_lift": x["t_lift"], "t_search": x["t_search"],
                           "t_touchdown": x.get("t_touchdown"),
                           "crab_deg_at_search": float(s["crab_deg"][int(round(x["t_search"] / 0.1))])}
                          for i, x in enumerate(trs)]}


def crab(p: CrabParams, log: Callable[[str], None]) -> str:
    led = _ledger(p, "crab", 1)
    led.run("crab", p.model_dump(mode="json", exclude={"json_out", "figure"}), 0, lambda: _crab_walk(p), log)
    return render_crab([led.data])


def render_crab(datas: list) -> str:
    data, res = _first(datas)
    if "crab" not in res:
        return missing(CRAB_JSON, _cmd("crab"))
    p, r = data["params"], res["crab"]
    d = r["during"] or {}
    rows = [[x["transfer"], x["tripod"], f"{x['t_lift']:.1f}", f"{x['t_search']:.1f}", _f(x["t_touchdown"], "{:.1f}"),
             f"{x['crab_deg_at_search']:.0f}"] for x in r["transfers"]]
    return (f"Crab angle commanded 0 -> {p['to_deg']:g} deg at {p['change_at_s']:g} s (ground {p['roughness_m']} m, no zones, "
            f"outcome {r['outcome']}):\n\n"
            f"- the new angle took effect at {_f(r['applied_s'], '{:.1f}')} s, when the transfer in progress at the command "
            f"had ended (tripod {d.get('tripod', '-')}, {_f(d.get('t_lift'), '{:.1f}')} -> {_f(d.get('t_touchdown'), '{:.1f}')} s), "
            "as in Figs. 11-12\n"
            f"- realised direction of travel (world): {_f(r['direction_before_deg'], '{:.1f}')} deg before, "
            f"{_f(r['direction_after_deg'], '{:.1f}')} deg after (commanded 0 and {p['to_deg']:g})\n"
            f"- body-frame heading drift over the walk: {r['heading_drift_deg']:.2f} deg\n\n"
            + md_table(["transfer", "tripod", "lift (s)", "search (s)", "touchdown (s)", "crab angle used (deg)"], rows))


# -- circling and spinning --------------------------------------------------------------------

class TurnParams(BaseModel):
    turn_rate_deg_s: float = Field(0.5, ge=-5.0, le=5.0)
    speed_m_s: float = Field(0.015, ge=0.0, le=0.03)
    distance_m: float = Field(1.0, gt=0.1, le=5.0)
    turn_deg: float = Field(90.0, gt=0.0, le=360.0)
    density_per_m2: float = Field(3.0, ge=0.0, le=20.0)
    roughness_m: float = Field(0.04, ge=0.0, le=0.09)
    json_out: Path | None = Field(Path(CIRCLING_JSON), description="the ledger (aware and unaware runs)")


class SpinParams(TurnParams):
    turn_rate_deg_s: float = Field(2.0, ge=-5.0, le=5.0)
    speed_m_s: float = Field(0.0, ge=0.0, le=0.0)
    json_out: Path | None = Field(Path(SPINNING_JSON), description="the ledger (aware and unaware runs)")


TURN_KEYS = ("outcome", "time_s", "transfers", "footholds", "footholds_in_zones", "min_sm_m", "min_k_r_m", "stop_time_s",
             "tracking_error_max_m")


def _turn_walk(p: TurnParams, gait: str, aware: bool) -> dict:
    ter, fld = _world(5.0, 5.0, p.roughness_m, 0, p.density_per_m2, 0)
    route = Route(gait=gait, speed=p.speed_m_s if gait == "circling" else 0.0, distance=p.distance_m,
                  turn_rate_deg_s=p.turn_rate_deg_s, turn_deg=p.turn_deg)
    r = walk(ter, fld, WalkConfig(route=route, aware=aware))
    s = r.summary()
    return {**{k: s[k] for k in TURN_KEYS}, "yaw_deg": math.degrees(r.steps["rpy"][-1][2] - r.steps["rpy"][0][2]),
            "end_xy": r.steps["pos"][-1, :2].tolist()}


def _turn(p: TurnParams, gait: str, log) -> str:
    led = _ledger(p, gait, 2)
    for aware in (True, False):
        name = "aware" if aware else "unaware"
        led.run(name, {"gait": gait, "aware": aware} | p.model_dump(mode="json", exclude={"json_out"}), 0,
                lambda aware=aware: _turn_walk(p, gait, aware), log)
    return render_turn(gait)([led.data])


def circling(p: TurnParams, log) -> str:
    return _turn(p, "circling", log)


def spinning(p: SpinParams, log) -> str:
    return _turn(p, "spinning", log)


def render_turn(gait: str) -> Callable[[list], str]:
    def render(datas: list) -> str:
        data, res = _first(datas)
        if not res:
            return missing(CIRCLING_JSON if gait == "circling" else SPINNING_JSON, _cmd(gait))
        p = data["params"]
        if gait == "circling":
            radius = p["speed_m_s"] / math.radians(abs(p["turn_rate_deg_s"]))
            head = (f"Circling: {p['speed_m_s']} m/s at {p['turn_rate_deg_s']:g} deg/s (radius {radius:.2f} m) for "
                    f"{p['distance_m']} m, {p['density_per_m2']:g} zones/m^2, ground {p['roughness_m']} m")
            expect = math.degrees(p["distance_m"] / radius)
        else:
            head = (f"Spinning: {p['turn_rate_deg_s']:g} deg/s to {p['turn_deg']:g} deg, {p['density_per_m2']:g} zones/m^2, "
                    f"ground {p['roughness_m']} m")
            expect = p["turn_deg"]
        rows = [[k, v["outcome"], f"{v['time_s']:.1f}", f"{v['yaw_deg']:.1f} ({expect:.1f})",
                 f"({v['end_xy'][0]:.2f}, {v['end_xy'][1]:.2f})", v["transfers"], v["footholds_in_zones"],
                 _f(v["min_sm_m"]), _f(v["min_k_r_m"]), f"{v['stop_time_s']:.1f}", _f(v["tracking_error_max_m"])]
                for k, v in res.items()]
        return head + ":\n\n" + md_table(["planner", "outcome", "time (s)", "yaw turned (deg; commanded)", "end (x, y) m",
                                          "transfers", "in zones", "min SM (m)", "min K_R", "stopped (s)",
                                          "track err (m)"], rows)
    return render
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
    arms: str = Field("exact,dgps,dgps_x4,unaware", description="of " + ", ".join(NOISE_ARMS) + " (dgps: position and "
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
    return (f"- **freegait** (paper 004): with DGPS-sized position and zone errors the zone-aware walk stepped into a "
            f"zone in {k} of {len(rs)} runs at {data['params']['density_per_m2']:g} zones/m^2 (rate {ci[0]:.2f}-{ci[1]:.2f}, "
            f"Clopper-Pearson 95 %) ([docs/freegait.md](docs/freegait.md)).\n")



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

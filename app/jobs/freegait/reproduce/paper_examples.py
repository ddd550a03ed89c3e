"""The paper's three simulation examples (Sec. 5.1) and its circling and spinning gaits:
``gaitmend reproduce freegait`` (example 1, k_ev), ``freegait-zones`` (example 2),
``freegait-crab`` (example 3), ``freegait-circling`` and ``freegait-spinning``; each run and
its rendering from the committed JSON."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from app.jobs import stats
from app.jobs.freegait.planner.params import GaitParams
from app.jobs.freegait.planner.route import Change, Route
from app.jobs.freegait.planner.walk import WalkConfig, walk
from app.jobs.ledger import current_runs
from app.jobs.reporting import md_table, missing, progress_note
from app.robots.silo6 import SILO6
from app.jobs.freegait.reproduce.walks import (CIRCLING_JSON, CRAB_JSON, KEV_JSON, KEVS, SPINNING_JSON, ZONES_JSON,
                                               _cmd, _f, _first, _ledger, _world)


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

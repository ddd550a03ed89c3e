"""The free-crab / circling / spinning gait executed in MuJoCo (Sec. 2-4 of paper 004).

The planner runs every 0.1 s (the paper's controller period) on simulated sensors only:
18 joint encoders (feet by forward kinematics), six foot switches (MuJoCo touch sensors),
body roll and pitch (the inclinometers, from the body quaternion) and the body's position
and heading (the paper's DGPS localisation; exact here). It does not know the ground: it
estimates the ground under a new foothold as the mean height of the feet in support (plus
``ground_bias``, the robustness case) and finds it by contact in subphase 3.

Each period: the foot-lifting planner (conditions 1 and 2, or the turn lifting condition),
the body motion planner (V_BH with its three stop cases, V_BV by Eq. 16, roll and pitch by
Eq. 17, the route's yaw rate), the transfer trajectories (Eq. 7-10, three subphases
synchronised per tripod), the foothold planner when a tripod has finished subphase 1; then
every foot's target in the body frame goes through the leg IK, and one ``mujoco.rollout``
call runs the period's physics steps with the joint targets ramped linearly.

Where the copy says nothing: when no candidate tripod is valid with the body moving, the
search is repeated with the body stopped for this transfer (R_T2 = R = 0 for it; the next
transfer is still planned at speed) — a body stop with cause "no_valid_tripod_at_speed";
when even that finds none the body stays stopped, and after ``stall_s`` the run ends with
cause "no_valid_tripod".
"""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np
from mujoco import rollout

from app.jobs.freegait.planner.geometry import Motion, kinematic_margin, polygon_margin, transfer_points, triangle_margin
from app.jobs.freegait.planner.params import GaitParams, nominal_re, r1, r3
from app.jobs.freegait.planner.route import Route
from app.jobs.freegait.planner.search import SearchInput, SearchResult, candidate_grid, evaluate, search
from app.robots import silo6
from app.robots.silo6 import SENSOR_SLICES, SILO6, Silo6Geometry
from app.jobs.freegait.terrain import Minefield, Terrain, add_heightfield, add_zone_markers

TRIPODS0 = tuple(tuple(l - 1 for l in t) for t in silo6.TRIPODS)  # leg indices 0..5, (F, C, R)
# A foothold the foot could not reach becomes a forbidden point (Sec. 3.3.3) of this radius:
# a foot (0.02 m) plus the touchdown error we measure (< 0.015 m), so the search moves on to
# the next candidate instead of clearing a mine-sized safe area around it.
MISSED_RADIUS = 0.04
STOP_CAUSES = ("", "stability", "kinematic", "touchdown_failed", "no_valid_tripod_at_speed", "no_valid_tripod")
PHASES = ("support", "subphase1", "subphase2", "subphase3")


@dataclasses.dataclass(frozen=True)
class WalkConfig:
    route: Route = Route()
    params: GaitParams = GaitParams()
    aware: bool = True  # the planner knows the forbidden zones
    chooser: str = "ev"  # ev | random (control: a random valid tripod) | periodic (control)
    ground_bias: float = 0.0  # error of the planner's ground-height estimate, m
    friction_scale: float = 1.0
    mass_scale: float = 1.0
    timestep: float = 0.002
    control_dt: float = 0.1
    kp_vertical: float = 1.0  # Eq. 16 gain, 1/s
    kp_attitude: float = 1.0  # Eq. 17 gains, 1/s
    touch_threshold_n: float = 5.0
    settle_s: float = 0.5
    stall_s: float = 10.0
    time_limit_factor: float = 4.0
    fall_tilt_deg: float = 30.0
    seed: int = 0


def build_spec(terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry = SILO6,
                markers: bool = True) -> mujoco.MjSpec:
    spec = silo6.base_spec(geom)
    spec.option.timestep = cfg.timestep
    add_heightfield(spec, terrain, friction=geom.friction * cfg.friction_scale)
    if markers:
        # the replay draws the zones near the route only (a large field holds thousands)
        add_zone_markers(spec, terrain, zones_near_route(field, cfg.route))
    silo6.add_robot(spec, dataclasses.replace(geom, friction=geom.friction * cfg.friction_scale))
    if cfg.mass_scale != 1.0:
        for b in spec.bodies:
            for gm in b.geoms:
                if gm.mass > 0:
                    gm.mass = gm.mass * cfg.mass_scale
    return spec


def zones_near_route(field: Minefield, route: Route, reach: float = 1.5) -> Minefield:
    """The zones within ``reach`` of the route's nominal COG path (a foot never goes farther)."""
    if len(field.centres) == 0:
        return field
    path = route.nominal_path()[::10, :2]
    d = np.linalg.norm(field.centres[:, None, :] - path[None, :, :], axis=-1).min(axis=1)
    return Minefield(field.centres[d < reach], field.zone_radius, field.safe_radius)


def _rot(q: np.ndarray) -> np.ndarray:
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, q)
    return m.reshape(3, 3)


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rp(roll: float, pitch: float) -> np.ndarray:
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return ry @ rx


@dataclasses.dataclass
class WalkResult:
    steps: dict[str, np.ndarray]  # per control period
    transfers: list[dict]  # one row per tripod transfer
    footholds: list[dict]  # one row per touchdown
    outcome: str  # finished | fallen | no_valid_tripod | time_limit
    model_xml: str
    sim_steps: int
    wall_s: float
    searches: int
    missed: list = dataclasses.field(default_factory=list)  # footholds that became forbidden (world xy)

    def summary(self) -> dict:
        """Numbers of the walk; a value that cannot exist (no transfer, no zone) is None, never NaN."""
        out = self._summary()
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}

    def _summary(self) -> dict:
        s = self.steps
        dt = float(s["t"][1] - s["t"][0]) if len(s["t"]) > 1 else 0.1
        moving = s["t"] > 0
        n_zone = sum(1 for f in self.footholds if f["in_zone"])
        n_safe = sum(1 for f in self.footholds if f["in_safe_area"])
        stop = s["stop"][moving] > 0
        sup = [tr for tr in self.transfers if tr.get("support_s") is not None]
        dev = [math.hypot(f["x"] - f["planned_x"], f["y"] - f["planned_y"]) for f in self.footholds
               if f["planned_x"] is not None]
        return {
            "outcome": self.outcome,
            "finished": self.outcome == "finished",
            "time_s": float(s["t"][-1]),
            "distance_m": float(s["progress"][-1]),
            "mean_speed_m_s": float(s["progress"][-1] / max(s["t"][-1], 1e-9)),
            "footholds": len(self.footholds),
            "footholds_in_zones": n_zone,
            "footholds_in_safe_areas": n_safe,
            "closest_zone_m": min((f["zone_distance"] for f in self.footholds if f["zone_distance"] is not None),
                                  default=None),
            "foothold_error_max_m": max(dev, default=0.0),  # touchdown vs planned F' (Eq. 18)
            "transfers": len(self.transfers),
            "failed_touchdowns": len(self.missed),
            "stop_time_s": float(stop.sum() * dt),
            "stop_time_by_cause_s": {c: float(((s["stop"] == i) & moving).sum() * dt) for i, c in enumerate(STOP_CAUSES) if i},
            "min_sm_m": float(np.nanmin(s["sm"][moving])) if moving.any() else float("nan"),
            "mean_sm_m": float(np.nanmean(s["sm"][moving])) if moving.any() else float("nan"),
            "min_k_r_m": float(np.nanmin(s["k_r"][moving])) if moving.any() else float("nan"),
            "tracking_error_max_m": float(np.max(s["track_err"])),
            "tracking_error_final_m": float(s["track_err"][-1]),
            "max_tilt_deg": float(np.degrees(np.max(np.abs(s["rpy"][:, :2])))),
            "mean_transfer_s": float(np.mean([tr["transfer_s"] for tr in self.transfers if tr.get("transfer_s")] or [np.nan])),
            "mean_support_s": float(np.mean([tr["support_s"] for tr in sup] or [np.nan])),
            "searches": self.searches,
            "sim_steps": self.sim_steps,
            "wall_s": self.wall_s,
        }


def stand_pose(geom: Silo6Geometry, terrain: Terrain) -> tuple[np.ndarray, np.ndarray]:
    """Initial body position and body-frame feet: nominal footholds on the ground."""
    feet = geom.nominal_feet()
    ground = terrain.height(feet[:, :2]) + geom.foot_radius
    z0 = float(ground.mean() + geom.stand_height)
    feet = feet.copy()
    feet[:, 2] = ground - z0
    return np.array([0.0, 0.0, z0]), feet


def walk(terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry = SILO6,
         cancel=None) -> WalkResult:
    t_wall = time.perf_counter()
    spec = build_spec(terrain, field, cfg, geom)
    model = spec.compile()
    xml = spec.to_xml()
    data = mujoco.MjData(model)
    route, base = cfg.route, cfg.params
    rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), 0xF6A1]))
    nsub = int(round(cfg.control_dt / cfg.timestep))
    dt = cfg.control_dt
    rects = geom.workspaces()
    zlo, zhi = geom.z_range

    pos0, feet0 = stand_pose(geom, terrain)
    data.qpos[:3] = pos0
    data.qpos[3] = 1.0
    q_cmd = silo6.leg_ik_body(geom, feet0).reshape(-1)
    data.qpos[7:] = q_cmd
    data.ctrl[:] = q_cmd
    mujoco.mj_forward(model, data)
    state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros(mujoco.mj_stateSize(model, state_spec))
    mujoco.mj_getState(model, data, state, state_spec)
    roller = rollout.Rollout(nthread=0)
    sim_steps = 0

    def run_period(q_from: np.ndarray, q_to: np.ndarray):
        nonlocal state, sim_steps
        u = (np.arange(1, nsub + 1) / nsub)[:, None]
        ctrl = (q_from[None, :] * (1 - u) + q_to[None, :] * u)[None]
        st, sens = roller.rollout(model, data, state[None], ctrl, nstep=nsub)
        state = st[0, -1].copy()
        sim_steps += nsub
        return sens[0]

    # settle on the initial stance
    sens = None
    for _ in range(int(round(cfg.settle_s / dt))):
        sens = run_period(q_cmd, q_cmd)

    phase = np.zeros(6, dtype=int)
    p_cmd = feet0.copy()  # commanded feet in the horizontal frame (support: ground-fixed)
    transfer: dict | None = None
    alpha = route.crab_angle(0.0)
    progress = 0.0
    yaw_turned = 0.0
    cmd_xy = np.array(pos0[:2])
    cmd_yaw = 0.0
    forbidden_extra: list[np.ndarray] = []
    transfers: list[dict] = []
    footholds: list[dict] = []
    last_touchdown = {0: 0.0, 1: 0.0}
    lifted_before: set[int] = set()
    stall = 0.0
    searches = 0
    rec = {k: [] for k in ("t", "pos", "rpy", "phase", "sm", "k_r", "v", "stop", "progress", "cmd_xy", "track_err",
                           "k_ev", "crab_deg", "qpos", "tips")}
    t_limit = route.nominal_duration() * cfg.time_limit_factor + 30.0
    outcome = "time_limit"
    k = 0
    v_nom, omega_nom = route.body_speed, route.omega

    def allowed_fn(pos_xy: np.ndarray, yaw: float):
        pts_extra = np.array(forbidden_extra) if forbidden_extra else np.zeros((0, 2))
        c, s = math.cos(yaw), math.sin(yaw)
        # only zones within reach of a foot can matter (candidates lie within 0.9 m of the body centre)
        near = field.centres[np.linalg.norm(field.centres - pos_xy[:2], axis=1) < 1.2] if len(field.centres) else field.centres
        local = Minefield(near, field.zone_radius, field.safe_radius)

        def allowed(p):
            w = np.stack([pos_xy[0] + c * p[..., 0] - s * p[..., 1], pos_xy[1] + s * p[..., 0] + c * p[..., 1]], -1)
            ok = np.ones(w.shape[:-1], dtype=bool)
            if cfg.aware:
                ok &= local.distance(w) >= field.safe_radius
            if len(pts_extra):
                ok &= np.linalg.norm(w[..., None, :] - pts_extra, axis=-1).min(axis=-1) >= MISSED_RADIUS
            return ok

        return allowed

    while True:
        t = k * dt
        if cancel is not None and k % 50 == 0 and cancel():
            outcome = "cancelled"
            break
        last = sens[-1]
        touch = sens[:, SENSOR_SLICES["touch"]].max(axis=0)
        q = last[SENSOR_SLICES["joints"]].reshape(6, 3)
        r_wb = _rot(last[SENSOR_SLICES["quat"]])
        pos = last[SENSOR_SLICES["pos"]]
        yaw = math.atan2(r_wb[1, 0], r_wb[0, 0])
        r_h = _rz(-yaw) @ r_wb
        pitch = math.asin(max(-1.0, min(1.0, -r_h[2, 0])))
        roll = math.atan2(r_h[2, 1], r_h[2, 2])
        feet_h = (r_h @ silo6.leg_fk_body(geom, q).T).T
        tips_w = last[SENSOR_SLICES["tips"]].reshape(6, 3)

        if abs(roll) > math.radians(cfg.fall_tilt_deg) or abs(pitch) > math.radians(cfg.fall_tilt_deg) or pos[2] < 0.12:
            outcome = "fallen"
            break
        done = (yaw_turned >= abs(math.radians(route.turn_deg))) if route.gait == "spinning" else (progress >= route.distance)
        if done:
            outcome = "finished"
            break
        if t > t_limit:
            break

        if transfer is None:
            alpha = route.crab_angle(t)  # a new crab angle takes effect between transfers (Figs. 11-12)
        params = dataclasses.replace(base, k_ev=route.k_ev(t, base.k_ev))
        motion = Motion(v_nom, alpha, omega_nom)
        rr1 = r1(motion, params)
        re = nominal_re(motion, params, geom.stroke)
        kl = kinematic_margin(feet_h[:, :2], rects, motion, rr1)
        support = phase == 0
        k_r = float(kl[support].min()) if support.any() else float("nan")
        sm = polygon_margin(feet_h[support, :2]) if support.sum() >= 3 else -math.inf

        # --- foot-lifting planner (both tripods in support) ---
        if transfer is None:
            ktri = [float(kl[list(tr)].min()) for tr in TRIPODS0]
            lift_t = int(np.argmin(ktri)) if ktri[0] != ktri[1] else 1  # tie: tripod 2 first (Sec. 5.1)
            other = TRIPODS0[1 - lift_t]
            lift = False
            if motion.kind == "spinning" or cfg.chooser == "periodic":
                lift = t - last_touchdown[1 - lift_t] >= 0.0  # turn lifting condition / periodic alternation
            else:
                fo = feet_h[list(other), :2]
                _, l_other, _ = transfer_points(fo[0], fo[1], fo[2], motion, re)
                sm_other = float(triangle_margin(fo[0], fo[1], fo[2]))
                if np.isfinite(l_other) and l_other <= 0.0:
                    lift = True  # foot-lifting condition 1: L = 0
                elif ktri[lift_t] <= 0.0 and sm_other > params.sm_min:
                    lift = True  # foot-lifting condition 2
            if lift:
                legs = list(TRIPODS0[lift_t])
                transfer = {"tri": lift_t, "legs": legs, "sub": 1, "tau": 0.0, "rise": 0.0, "t_lift": t,
                            "stopped": False, "failed_legs": 0, "row": {"tripod": lift_t + 1, "t_lift": round(t, 3)}}
                phase[legs] = 1

        # --- body motion planner ---
        cause = 0
        if transfer is not None and transfer.get("hold"):
            cause = transfer["hold"]
        elif transfer is not None and transfer["stopped"]:
            cause = 4
        elif support.sum() >= 3 and sm <= params.sm_min and motion.kind != "spinning":
            cause = 1
        elif support.any() and k_r <= 0.0:
            cause = 2
        v = 0.0 if cause else v_nom
        w = 0.0 if cause else omega_nom
        inside = all(rects[i, 0] <= feet_h[i, 0] <= rects[i, 1] and rects[i, 2] <= feet_h[i, 1] <= rects[i, 3]
                     for i in np.flatnonzero(support))
        height = -float(feet_h[support, 2].mean()) if support.any() else geom.stand_height
        v_bv = cfg.kp_vertical * (geom.stand_height - height) if inside else 0.0
        roll_des = roll * (1.0 - cfg.kp_attitude * dt) if inside else roll
        pitch_des = pitch * (1.0 - cfg.kp_attitude * dt) if inside else pitch

        # ground-fixed motion of every foot not in subphase 2 (support, rising, descending)
        d = np.array([math.cos(alpha), math.sin(alpha)])
        rz = _rz(-w * dt)[:2, :2]
        fixed = phase != 2
        p_cmd[fixed, :2] = (p_cmd[fixed, :2] - v * dt * d) @ rz.T
        p_cmd[fixed, 2] -= v_bv * dt

        # --- transfer phase ---
        if transfer is not None:
            legs = transfer["legs"]
            transfer["tau"] += dt
            if transfer["sub"] == 1:
                step = min(params.v1 * dt, params.h1 - transfer["rise"])
                p_cmd[legs, 2] += step
                transfer["rise"] += step
                if transfer["rise"] >= params.h1 - 1e-9:
                    # --- foothold planner, at P_1 ---
                    p1 = feet_h[legs, :2]
                    sup_legs = list(TRIPODS0[1 - transfer["tri"]])
                    k_sup = float(kl[sup_legs].min())
                    if cfg.chooser == "periodic":
                        cand_best = np.stack([candidate_grid(rects[l], motion.local_direction(geom.workspace_centre(l + 1)),
                                                             base.n_candidates, params)[-1 if base.n_candidates < 6 else -2]
                                              for l in legs])
                        res = None
                        chosen = cand_best
                    else:
                        cand = np.stack([candidate_grid(rects[l], motion.local_direction(geom.workspace_centre(l + 1)),
                                                        params.n_candidates, params) for l in legs])
                        inp = SearchInput(motion, params, cand, p1, rects[legs], k_sup, re,
                                          allowed_fn(pos[:2], yaw))
                        pick = rng if cfg.chooser == "random" else None
                        res = search(inp, pick)
                        searches += 1
                        if not res.found:
                            # the same search with the body stopped for this transfer
                            res0 = _search_stopped(inp, pick)
                            searches += 1
                            if res0 is not None and res0.found:
                                transfer["stopped"] = True
                                res = res0
                        chosen = res.footholds if res is not None and res.found else None
                    if chosen is None:
                        transfer["hold"] = 5
                        stall += dt
                        if stall >= cfg.stall_s:
                            outcome = "no_valid_tripod"
                            _record(rec, t, pos, roll, pitch, yaw, phase, sm, k_r, v, 5, progress, cmd_xy, data, state,
                                    model, params, alpha, tips_w)
                            break
                    else:
                        stall = 0.0
                        transfer.pop("hold", None)
                        est = float(feet_h[sup_legs, 2].mean()) + cfg.ground_bias
                        dx = np.abs(chosen[:, 0] - feet_h[legs, 0])
                        transfer.update(sub=2, tau=0.0, p1=p_cmd[legs].copy(), F=chosen.copy(), est=est,
                                        t2=np.maximum(dx / params.v2, dt), desc=np.zeros(3), touched=np.zeros(3, bool))
                        row = transfer["row"]
                        row.update(t_search=round(t, 3), stopped=transfer["stopped"])
                        if res is not None:
                            row.update(ev=res.ev, k=res.k, sm_t=res.sm_t, l=res.l, r_t2=res.r_t2, valid=res.counts["valid"],
                                       index=list(res.index))
                            c, s_ = math.cos(yaw), math.sin(yaw)
                            gp = res.ground_points
                            transfer["planned_w"] = np.stack([pos[0] + c * gp[:, 0] - s_ * gp[:, 1],
                                                              pos[1] + s_ * gp[:, 0] + c * gp[:, 1]], -1)
                        phase[legs] = 2
            elif transfer["sub"] == 2:
                tau = transfer["tau"]
                z2 = transfer["est"] + params.h3 / 2
                for n_, l in enumerate(legs):
                    u = min(tau / transfer["t2"][n_], 1.0)
                    p1 = transfer["p1"][n_]
                    p_cmd[l, :2] = p1[:2] + u * (transfer["F"][n_] - p1[:2])
                    line = p1[2] + u * (z2 - p1[2])
                    p_cmd[l, 2] = max(line, transfer["est"] + params.h2 * (1.0 - u))
                if tau >= transfer["t2"].max() - 1e-9:
                    transfer.update(sub=3, tau=0.0)
                    transfer["row"]["t_sub3"] = round(t, 3)
                    phase[legs] = 3
            else:
                for n_, l in enumerate(legs):
                    if transfer["touched"][n_]:
                        continue
                    if touch[l] > cfg.touch_threshold_n:
                        transfer["touched"][n_] = True
                        p_cmd[l] = feet_h[l]  # hold where the switch closed
                        phase[l] = 0
                        continue
                    step = params.v3 * dt
                    p_cmd[l, 2] -= step
                    transfer["desc"][n_] += step
                resolved = transfer["touched"] | (transfer["desc"] >= params.h3 - 1e-9) | (p_cmd[legs, 2] < zlo)
                if resolved.all():
                    row = transfer["row"]
                    if transfer["touched"].all():
                        row.update(t_touchdown=round(t, 3), transfer_s=round(t - transfer["t_lift"], 3),
                                   failed_legs=transfer["failed_legs"])
                        # the tripod's support phase before this transfer (none before the first lift)
                        first = transfer["tri"] not in lifted_before
                        row["support_s"] = None if first else round(transfer["t_lift"] - last_touchdown[transfer["tri"]], 3)
                        lifted_before.add(transfer["tri"])
                        planned = transfer.get("planned_w")
                        for n_, l in enumerate(legs):
                            xy = tips_w[l, :2]
                            footholds.append({
                                "t": round(t, 3), "leg": l + 1, "tripod": transfer["tri"] + 1,
                                "x": float(xy[0]), "y": float(xy[1]), "z": float(tips_w[l, 2]),
                                "planned_x": float(planned[n_, 0]) if planned is not None else None,
                                "planned_y": float(planned[n_, 1]) if planned is not None else None,
                                "zone_distance": float(field.distance(xy)) if len(field.centres) else None,
                                "in_zone": bool(field.in_zone(xy)), "in_safe_area": bool(field.in_safe_area(xy)),
                            })
                        last_touchdown[transfer["tri"]] = t
                        transfers.append(row)
                        phase[legs] = 0
                        transfer = None
                    else:
                        # Sec. 3.3.3: the missed footholds become forbidden; lift again and search anew
                        planned = transfer.get("planned_w")
                        for n_, l in enumerate(legs):
                            if not transfer["touched"][n_]:
                                xy = planned[n_] if planned is not None else np.array(
                                    [pos[0] + math.cos(yaw) * feet_h[l, 0] - math.sin(yaw) * feet_h[l, 1],
                                     pos[1] + math.sin(yaw) * feet_h[l, 0] + math.cos(yaw) * feet_h[l, 1]])
                                forbidden_extra.append(np.asarray(xy, dtype=float))
                        transfer["failed_legs"] += int((~transfer["touched"]).sum())
                        transfer.update(sub=1, tau=0.0, rise=0.0, hold=3)
                        phase[legs] = 1

        # --- joint targets through IK ---
        r_des = _rp(roll_des, pitch_des)
        feet_b = (r_des.T @ p_cmd.T).T
        q_new = silo6.leg_ik_body(geom, feet_b).reshape(-1)

        # route bookkeeping: the commanded path the body should follow
        cmd_xy = cmd_xy + v * dt * np.array([math.cos(cmd_yaw + alpha), math.sin(cmd_yaw + alpha)])
        cmd_yaw += w * dt
        progress += v * dt
        yaw_turned += abs(w) * dt
        _record(rec, t, pos, roll, pitch, yaw, phase, sm, k_r, v, cause, progress, cmd_xy, data, state, model, params,
                alpha, tips_w)
        sens = run_period(q_cmd, q_new)
        q_cmd = q_new
        k += 1

    steps = {key: np.asarray(val) for key, val in rec.items()}
    return WalkResult(steps=steps, transfers=transfers, footholds=footholds, outcome=outcome, model_xml=xml,
                      sim_steps=sim_steps, wall_s=time.perf_counter() - t_wall, searches=searches,
                      missed=[p.tolist() for p in forbidden_extra])


def _search_stopped(inp: SearchInput, pick):
    """Support conditions with the body stopped during this transfer: its R_T2, R_3 and R
    are zero (so conditions 2, 4 and 6 lose those terms and F' = F), while K keeps the R_1
    of the next lift at speed and R_e stays the nominal one (the next transfer is at speed)."""
    e = evaluate(inp)
    conds = dict(e["conds"])
    if "c2_support_margin" in conds:
        conds["c1_zones"] = _zones_unshifted(inp)
        conds["c2_support_margin"] = e["l"] < inp.k_support
        conds["c4_touchdown"] = e["l"] > 0.0  # this transfer's R_3 is zero too
        conds["c6_displacement"] = np.ones_like(conds["c6_displacement"])
    else:
        conds["t1_zones"] = _zones_unshifted(inp)
        conds["t4_turn"] = np.ones_like(conds["t4_turn"])
    valid = np.logical_and.reduce(list(conds.values()))
    if not valid.any():
        return None
    flat = int(np.argmax(np.where(valid, e["ev"], -np.inf))) if pick is None else int(pick.choice(np.flatnonzero(valid)))
    a, b, c = (int(x) for x in np.unravel_index(flat, valid.shape))
    cand = inp.candidates
    fh = np.stack([cand[0, a], cand[1, b], cand[2, c]])
    counts = {n: int(v.sum()) for n, v in conds.items()}
    counts["valid"] = int(valid.sum())
    return SearchResult(True, (a, b, c), fh, fh.copy(), float(e["ev"][a, b, c]), float(e["k"][a, b, c]),
                        float(e["sm_t"][a, b, c]), float(e["l"][a, b, c]), 0.0, counts)


def _zones_unshifted(inp: SearchInput) -> np.ndarray:
    cand = inp.candidates
    ok = np.ones(cand.shape[:2], dtype=bool) if inp.allowed is None else np.asarray(inp.allowed(cand), dtype=bool)
    return ok[0][:, None, None] & ok[1][None, :, None] & ok[2][None, None, :]


def _record(rec, t, pos, roll, pitch, yaw, phase, sm, k_r, v, cause, progress, cmd_xy, data, state, model, params,
            alpha, tips_w):
    rec["t"].append(t)
    rec["pos"].append(np.array(pos))
    rec["rpy"].append((roll, pitch, yaw))
    rec["phase"].append(phase.copy())
    rec["sm"].append(sm if np.isfinite(sm) else np.nan)
    rec["k_r"].append(k_r)
    rec["v"].append(v)
    rec["stop"].append(cause)
    rec["progress"].append(progress)
    rec["cmd_xy"].append(cmd_xy.copy())
    rec["track_err"].append(float(np.linalg.norm(np.asarray(pos[:2]) - cmd_xy)))
    rec["k_ev"].append(params.k_ev)
    rec["crab_deg"].append(math.degrees(alpha))
    rec["qpos"].append(state[1:1 + model.nq].copy())
    rec["tips"].append(tips_w.copy())

"""One walk's control loop (paper 004, Sec. 2-4; app/jobs/freegait/planner/walk.py tells the
whole method): every control period the foot-lifting planner, the body motion planner, the
transfer subphases with the foothold search, the joint targets, then the period's
physics."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from app.jobs.freegait.planner.geometry import Motion, kinematic_margin, polygon_margin, transfer_points, triangle_margin
from app.jobs.freegait.planner.params import nominal_re, r1
from app.jobs.freegait.planner.search import SearchInput, SearchResult, candidate_grid, evaluate, search
from app.jobs.freegait.planner.walk_config import CAUSE_INDEX, TRIPODS0, WalkConfig, stand_pose
from app.jobs.freegait.planner.walk_record import WalkRecorder, WalkResult
from app.jobs.freegait.planner.walk_sim import Sensors, WalkSim, roll_pitch_matrix, world_xy, yaw_matrix
from app.jobs.freegait.planner.walk_state import AllowedFootholds, GaitState, Period, Transfer
from app.robots import silo6
from app.robots.silo6 import Silo6Geometry
from app.jobs.freegait.terrain import Minefield, Terrain


class Walker:
    """One walk: every control period the foot-lifting planner, the body motion planner,
    the transfer subphases (the foothold planner at the end of subphase 1), the joint
    targets, then the period's physics."""

    def __init__(self, terrain: Terrain, field: Minefield, cfg: WalkConfig, geom: Silo6Geometry):
        self.cfg, self.geom, self.field = cfg, geom, field
        self.route, self.base = cfg.route, cfg.params
        self.rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), 0xF6A1]))
        self.dt = cfg.control_dt
        self.rects = geom.workspaces()
        self.zlo = geom.z_range[0]
        pos0, feet0 = stand_pose(geom, terrain)
        self.q_cmd = silo6.leg_ik_body(geom, feet0).reshape(-1)
        self.sim = WalkSim(terrain, field, cfg, geom, pos0, self.q_cmd)
        self.sens = None
        for _ in range(int(round(cfg.settle_s / self.dt))):  # settle on the initial stance
            self.sens = self.sim.period(self.q_cmd, self.q_cmd)
        self.g = GaitState(phase=np.zeros(6, dtype=int), p_cmd=feet0.copy(), cmd_xy=np.array(pos0[:2]),
                            alpha=self.route.crab_angle(0.0))
        self.rec = WalkRecorder()
        self.known, self.loc_err, self.err_rng = field, np.zeros(2), None
        if cfg.position_error_m > 0 or cfg.zone_error_m > 0:  # its own stream: the exact walk draws nothing
            self.err_rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), 0xD695]))
            if cfg.zone_error_m > 0 and len(field.centres):
                self.known = Minefield(field.centres + self.err_rng.normal(0.0, cfg.zone_error_m, field.centres.shape),
                                       field.zone_radius, field.safe_radius)
            self.loc_err = self.err_rng.normal(0.0, cfg.position_error_m, 2)
        self.t_limit = self.route.nominal_duration() * cfg.time_limit_factor + 30.0
        self.v_nom, self.omega_nom = self.route.body_speed, self.route.omega

    def period(self, k: int, cancel) -> bool:
        """Control period ``k``; False when the walk has ended (``g.outcome`` says how)."""
        t = k * self.dt
        if cancel is not None and k % 50 == 0 and cancel():
            self.g.outcome = "cancelled"
            return False
        s = Sensors.read(self.sens, self.geom)
        if self.ended(t, s):
            return False
        self.localise()
        p = self.margins(t, s)
        if self.g.transfer is None:
            self.lift_feet(p)
        self.move_body(p)
        if self.g.transfer is not None and not self.transfer_step(p):
            return False
        q_new = self.joint_targets(p)
        self.follow_route(p)
        self.rec.row(p, self.g, self.sim)
        self.sens = self.sim.period(self.q_cmd, q_new)
        self.q_cmd = q_new
        return True

    def localise(self) -> None:
        """One control period of the localisation error (Gauss-Markov, stationary spread
        ``position_error_m`` per axis)."""
        if self.err_rng is not None and self.cfg.position_error_m > 0:
            a = math.exp(-self.dt / self.cfg.position_error_tau_s)
            self.loc_err = a * self.loc_err + math.sqrt(1 - a * a) * self.err_rng.normal(0.0, self.cfg.position_error_m, 2)

    def believed(self, pos: np.ndarray) -> np.ndarray:
        """Where the planner believes the body is (horizontal): the true position plus the
        localisation error."""
        return np.asarray(pos[:2]) + self.loc_err

    def ended(self, t: float, s: Sensors) -> bool:
        cfg, route, g = self.cfg, self.route, self.g
        if abs(s.roll) > math.radians(cfg.fall_tilt_deg) or abs(s.pitch) > math.radians(cfg.fall_tilt_deg) or s.pos[2] < 0.12:
            g.outcome = "fallen"
            return True
        done = (g.yaw_turned >= abs(math.radians(route.turn_deg))) if route.gait == "spinning" else (g.progress >= route.distance)
        if done:
            g.outcome = "finished"
            return True
        return t > self.t_limit

    def margins(self, t: float, s: Sensors) -> Period:
        g = self.g
        if g.transfer is None:
            g.alpha = self.route.crab_angle(t)  # a new crab angle takes effect between transfers (Figs. 11-12)
        params = dataclasses.replace(self.base, k_ev=self.route.k_ev(t, self.base.k_ev))
        motion = Motion(self.v_nom, g.alpha, self.omega_nom)
        rr1 = r1(motion, params)
        re = nominal_re(motion, params, self.geom.stroke)
        kl = kinematic_margin(s.feet_h[:, :2], self.rects, motion, rr1)
        support = g.phase == 0
        k_r = float(kl[support].min()) if support.any() else float("nan")
        sm = polygon_margin(s.feet_h[support, :2]) if support.sum() >= 3 else -math.inf
        return Period(t, s, params, motion, re, kl, support, k_r, sm)

    # -- foot-lifting planner (both tripods in support) -----------------------------------

    def lift_feet(self, p: Period) -> None:
        ktri = [float(p.kl[list(tr)].min()) for tr in TRIPODS0]
        lift_t = int(np.argmin(ktri)) if ktri[0] != ktri[1] else 1  # tie: tripod 2 first (Sec. 5.1)
        if self.should_lift(p, ktri, lift_t):
            legs = list(TRIPODS0[lift_t])
            self.g.transfer = Transfer(tri=lift_t, legs=legs, t_lift=p.t, row={"tripod": lift_t + 1, "t_lift": round(p.t, 3)})
            self.g.phase[legs] = 1

    def should_lift(self, p: Period, ktri: list[float], lift_t: int) -> bool:
        if p.motion.kind == "spinning" or self.cfg.chooser == "periodic":
            return p.t - self.g.last_touchdown[1 - lift_t] >= 0.0  # turn lifting condition / periodic alternation
        fo = p.s.feet_h[list(TRIPODS0[1 - lift_t]), :2]
        _, l_other, _ = transfer_points(fo[0], fo[1], fo[2], p.motion, p.re)
        sm_other = float(triangle_margin(fo[0], fo[1], fo[2]))
        if np.isfinite(l_other) and l_other <= 0.0:
            return True  # foot-lifting condition 1: L = 0
        return ktri[lift_t] <= 0.0 and sm_other > p.params.sm_min  # foot-lifting condition 2

    # -- body motion planner ---------------------------------------------------------------

    def move_body(self, p: Period) -> None:
        """V_BH with its stop cases, V_BV (Eq. 16), roll and pitch (Eq. 17), then the
        ground-fixed motion of every foot not in subphase 2 (support, rising, descending)."""
        cfg, geom, g, s, dt = self.cfg, self.geom, self.g, p.s, self.dt
        p.cause = self.stop_cause(p)
        p.v = 0.0 if p.cause else self.v_nom
        p.w = 0.0 if p.cause else self.omega_nom
        rects = self.rects
        inside = all(rects[i, 0] <= s.feet_h[i, 0] <= rects[i, 1] and rects[i, 2] <= s.feet_h[i, 1] <= rects[i, 3]
                     for i in np.flatnonzero(p.support))
        height = -float(s.feet_h[p.support, 2].mean()) if p.support.any() else geom.stand_height
        p.v_bv = cfg.kp_vertical * (geom.stand_height - height) if inside else 0.0
        p.roll_des = s.roll * (1.0 - cfg.kp_attitude * dt) if inside else s.roll
        p.pitch_des = s.pitch * (1.0 - cfg.kp_attitude * dt) if inside else s.pitch
        d = np.array([math.cos(g.alpha), math.sin(g.alpha)])
        rz = yaw_matrix(-p.w * dt)[:2, :2]
        fixed = g.phase != 2
        g.p_cmd[fixed, :2] = (g.p_cmd[fixed, :2] - p.v * dt * d) @ rz.T
        g.p_cmd[fixed, 2] -= p.v_bv * dt

    def stop_cause(self, p: Period) -> int:
        tr = self.g.transfer
        if tr is not None and tr.hold:
            return tr.hold
        if tr is not None and tr.stopped:
            return CAUSE_INDEX["no_valid_tripod_at_speed"]
        if p.support.sum() >= 3 and p.sm <= p.params.sm_min and p.motion.kind != "spinning":
            return CAUSE_INDEX["stability"]
        if p.support.any() and p.k_r <= 0.0:
            return CAUSE_INDEX["kinematic"]
        return 0

    # -- transfer phase: three subphases, synchronised per tripod --------------------------

    def transfer_step(self, p: Period) -> bool:
        """False when the walk ends here (no valid tripod for ``stall_s``)."""
        tr = self.g.transfer
        tr.tau += self.dt
        if tr.sub == 1:
            return self.rise(p, tr)
        if tr.sub == 2:
            self.swing(p, tr)
        else:
            self.descend(p, tr)
        return True

    def rise(self, p: Period, tr: Transfer) -> bool:
        """Subphase 1: straight up by H1 at V1; at P_1 the foothold planner runs."""
        step = min(p.params.v1 * self.dt, p.params.h1 - tr.rise)
        self.g.p_cmd[tr.legs, 2] += step
        tr.rise += step
        if tr.rise >= p.params.h1 - 1e-9:
            return self.plan_footholds(p, tr)
        return True

    def plan_footholds(self, p: Period, tr: Transfer) -> bool:
        g = self.g
        sup_legs = list(TRIPODS0[1 - tr.tri])
        chosen, res = self.choose_footholds(p, tr, sup_legs)
        if chosen is None:
            tr.hold = CAUSE_INDEX["no_valid_tripod"]
            g.stall += self.dt
            if g.stall >= self.cfg.stall_s:
                g.outcome = "no_valid_tripod"
                self.rec.row(p, g, self.sim, cause=tr.hold)
                return False
            return True
        g.stall = 0.0
        tr.hold = 0
        est = float(p.s.feet_h[sup_legs, 2].mean()) + self.cfg.ground_bias
        dx = np.abs(chosen[:, 0] - p.s.feet_h[tr.legs, 0])
        tr.sub, tr.tau, tr.p1, tr.F, tr.est = 2, 0.0, g.p_cmd[tr.legs].copy(), chosen.copy(), est
        tr.t2, tr.desc, tr.touched = np.maximum(dx / p.params.v2, self.dt), np.zeros(3), np.zeros(3, bool)
        tr.row.update(t_search=round(p.t, 3), stopped=tr.stopped)
        if res is not None:
            tr.row.update(ev=res.ev, k=res.k, sm_t=res.sm_t, l=res.l, r_t2=res.r_t2, valid=res.counts["valid"],
                          index=list(res.index))
            tr.planned_w = world_xy(self.believed(p.s.pos), p.s.yaw, res.ground_points)
        g.phase[tr.legs] = 2
        return True

    def choose_footholds(self, p: Period, tr: Transfer, sup_legs: list[int]):
        """(footholds or None, the search's result or None): the best valid tripod by Ev, a
        random valid one (control), or the periodic control's fixed points (no search)."""
        n = p.params.n_candidates
        cand = np.stack([candidate_grid(self.rects[l], p.motion.local_direction(self.geom.workspace_centre(l + 1)),
                                        n, p.params) for l in tr.legs])
        if self.cfg.chooser == "periodic":
            return cand[:, -1 if n < 6 else -2], None
        inp = SearchInput(p.motion, p.params, cand, p.s.feet_h[tr.legs, :2], self.rects[tr.legs],
                          float(p.kl[sup_legs].min()), p.re,
                          AllowedFootholds.at(self.known, self.cfg.aware, self.g.missed, self.believed(p.s.pos), p.s.yaw))
        pick = self.rng if self.cfg.chooser == "random" else None
        res = search(inp, pick)
        self.g.searches += 1
        if not res.found:
            # the same search with the body stopped for this transfer
            res0 = _search_stopped(inp, pick)
            self.g.searches += 1
            if res0 is not None and res0.found:
                tr.stopped = True
                res = res0
        return (res.footholds if res.found else None), res

    def swing(self, p: Period, tr: Transfer) -> None:
        """Subphase 2: to above F on the line to the estimated ground + H3/2, never below
        the estimate + H2 (1 - u)."""
        p_cmd, tau = self.g.p_cmd, tr.tau
        z2 = tr.est + p.params.h3 / 2
        for n_, l in enumerate(tr.legs):
            u = min(tau / tr.t2[n_], 1.0)
            p1 = tr.p1[n_]
            p_cmd[l, :2] = p1[:2] + u * (tr.F[n_] - p1[:2])
            line = p1[2] + u * (z2 - p1[2])
            p_cmd[l, 2] = max(line, tr.est + p.params.h2 * (1.0 - u))
        if tau >= tr.t2.max() - 1e-9:
            tr.sub, tr.tau = 3, 0.0
            tr.row["t_sub3"] = round(p.t, 3)
            self.g.phase[tr.legs] = 3

    def descend(self, p: Period, tr: Transfer) -> None:
        """Subphase 3: down at V3 until each foot switch closes, at most H3."""
        g = self.g
        for n_, l in enumerate(tr.legs):
            if tr.touched[n_]:
                continue
            if p.s.touch[l] > self.cfg.touch_threshold_n:
                tr.touched[n_] = True
                g.p_cmd[l] = p.s.feet_h[l]  # hold where the switch closed
                g.phase[l] = 0
                continue
            step = p.params.v3 * self.dt
            g.p_cmd[l, 2] -= step
            tr.desc[n_] += step
        resolved = tr.touched | (tr.desc >= p.params.h3 - 1e-9) | (g.p_cmd[tr.legs, 2] < self.zlo)
        if resolved.all():
            if tr.touched.all():
                self.touch_down(p, tr)
            else:
                self.missed_touchdown(p, tr)

    def touch_down(self, p: Period, tr: Transfer) -> None:
        g, t = self.g, p.t
        tr.row.update(t_touchdown=round(t, 3), transfer_s=round(t - tr.t_lift, 3), failed_legs=tr.failed_legs)
        # the tripod's support phase before this transfer (none before the first lift)
        first = tr.tri not in g.lifted_before
        tr.row["support_s"] = None if first else round(tr.t_lift - g.last_touchdown[tr.tri], 3)
        g.lifted_before.add(tr.tri)
        g.footholds += [self.foothold(p, tr, n_, l) for n_, l in enumerate(tr.legs)]
        g.last_touchdown[tr.tri] = t
        g.transfers.append(tr.row)
        g.phase[tr.legs] = 0
        g.transfer = None

    def foothold(self, p: Period, tr: Transfer, n_: int, l: int) -> dict:
        xy = p.s.tips_w[l, :2]
        planned, field = tr.planned_w, self.field
        return {
            "t": round(p.t, 3), "leg": l + 1, "tripod": tr.tri + 1,
            "x": float(xy[0]), "y": float(xy[1]), "z": float(p.s.tips_w[l, 2]),
            "planned_x": float(planned[n_, 0]) if planned is not None else None,
            "planned_y": float(planned[n_, 1]) if planned is not None else None,
            "zone_distance": float(field.distance(xy)) if len(field.centres) else None,
            "in_zone": bool(field.in_zone(xy)), "in_safe_area": bool(field.in_safe_area(xy)),
        }

    def missed_touchdown(self, p: Period, tr: Transfer) -> None:
        """Sec. 3.3.3: the missed footholds become forbidden; lift again and search anew."""
        g = self.g
        for n_, l in enumerate(tr.legs):
            if not tr.touched[n_]:
                xy = tr.planned_w[n_] if tr.planned_w is not None else world_xy(self.believed(p.s.pos), p.s.yaw,
                                                                                  p.s.feet_h[l, :2])
                g.missed.append(np.asarray(xy, dtype=float))
        tr.failed_legs += int((~tr.touched).sum())
        tr.sub, tr.tau, tr.rise, tr.hold = 1, 0.0, 0.0, CAUSE_INDEX["touchdown_failed"]
        g.phase[tr.legs] = 1

    # -- the period's commands --------------------------------------------------------------

    def joint_targets(self, p: Period) -> np.ndarray:
        r_des = roll_pitch_matrix(p.roll_des, p.pitch_des)
        feet_b = (r_des.T @ self.g.p_cmd.T).T
        return silo6.leg_ik_body(self.geom, feet_b).reshape(-1)

    def follow_route(self, p: Period) -> None:
        """The commanded path the body should follow (tracking error, the end of the route)."""
        g, dt = self.g, self.dt
        g.cmd_xy = g.cmd_xy + p.v * dt * np.array([math.cos(g.cmd_yaw + g.alpha), math.sin(g.cmd_yaw + g.alpha)])
        g.cmd_yaw += p.w * dt
        g.progress += p.v * dt
        g.yaw_turned += abs(p.w) * dt

    def result(self, t_wall: float) -> WalkResult:
        g = self.g
        return WalkResult(steps=self.rec.arrays(), transfers=g.transfers, footholds=g.footholds, outcome=g.outcome,
                          model_xml=self.sim.xml, sim_steps=self.sim.sim_steps, wall_s=time.perf_counter() - t_wall,
                          searches=g.searches, missed=[m.tolist() for m in g.missed])


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

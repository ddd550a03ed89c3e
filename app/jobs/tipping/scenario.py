"""Tipping scenarios in MuJoCo (paper 002 Sec. 5): the tilting platform and tripod walking
onto a unilateral cliff, with the judgment-and-recovery controller running every control
step (0.02 s, the paper's sample time) on the simulated contact forces.

The controller is app/jobs/tipping/controller.py, the simulated robot
app/jobs/tipping/hexapod_sim.py; both are re-exported here, where the kind, its evidence
and its reproductions import them from."""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np

from app.robots.heavy_hexapod import HEAVY, LEG_IDS, HeavyHexapodGeometry
# the controller's and the simulated robot's names are re-exported for the kind's modules
from app.jobs.tipping.controller import (PAPER_EDGES, Adjustment, ControllerConfig, StepMonitor, TippingController,
                                         edge_name, monitor, planner_workspace)
from app.jobs.tipping.hexapod_sim import HexapodSim
from app.jobs.tipping.stability.polygon import ccw_order

# Tipped over: the body turned this far off the ground plane, i.e. it rotated about a
# support edge until something else hit the ground (the controlled robot stays within 3 deg).
TIPPED_DEG = 10.0
AFTER_TIP_S = 3.0  # keep simulating the fall this long, for the plots and the replay


# -- results ----------------------------------------------------------------------------------

def first_catch(adjs: list[dict]) -> dict | None:
    """The first adjustment that actually swung a leg."""
    return next((a for a in adjs if a["leg"] is not None), None)


def run_summary(r: dict, threshold: float) -> dict:
    """What a user reads about one simulation."""
    tr = r["trace"]
    t, m = tr["time_s"], tr["fasm_deg"]
    active = t >= 1.0
    below = np.where(active & (m < threshold))[0]
    first = first_catch(r["adjustments"])
    out = {
        "tipped": r["tipped"], "tipped_at_s": r["tipped_at_s"],
        "first_below_threshold_s": float(t[below[0]]) if len(below) else None,
        "min_margin_deg": float(m[active].min()), "final_margin_deg": float(m[-1]),
        "final_body_tilt_deg": float(tr["tilt_rel_deg"][-1]),
        "adjustments": r["adjustments"], "final_stance": r["final_stance"],
    }  # measured times (control_ms_*) stay out: the same spec must give the same summary
    for k in ("static_tip_deg", "max_tilt_deg", "distance_m", "max_slip_m"):
        if k in r:
            out[k] = r[k]
    if first is not None:
        out.update(detection_time_s=first["detect_time_s"], tipping_edge=first["edge"], adjustment_leg=first["leg"],
                   foothold_body_m=first["foothold_body_m"], foothold_label=first["foothold_label"],
                   time_to_tip_s=first["time_to_tip_s"], adjustment_time_s=first["adjustment_time_s"],
                   margin_at_detection_deg=first["margin_at_detection_deg"],
                   margin_before_landing_deg=first["margin_before_landing_deg"],
                   margin_after_landing_deg=first["margin_after_landing_deg"])
    return out


# -- the control loop both scenarios share ------------------------------------------------------

def _with_friction(geom: HeavyHexapodGeometry, friction: float | None) -> HeavyHexapodGeometry:
    return geom if friction is None else dataclasses.replace(geom, friction=friction)


class _World:
    """A scenario as the shared control loop (``_simulate``) sees it: the simulated robot,
    the feet's targets and first stance, what the ground does and what the run reports
    beyond the common result. The defaults are level ground that stays still."""

    control_from_s = 1.0  # the judgment starts here: before, the robot is still dropping onto its feet
    drives_stance = True  # stance legs follow ``targets`` too (a gait moves them)
    ground_check = None  # world point -> is there ground to stand on (None: everywhere)

    def __init__(self, sim: HexapodSim, targets: dict[int, np.ndarray], stance: list[int]):
        self.sim, self.targets, self.stance = sim, targets, stance

    def control_steps(self, n_ctl: int, control_dt: float) -> int:
        return n_ctl

    def before_control(self, t: float, ctl: TippingController) -> None:
        """At each control step, before the legs are commanded."""

    def platform_tilt_deg(self, t: float) -> float:
        return 0.0

    def ground_rotation(self) -> np.ndarray:
        return np.eye(3)

    def body_tilt_deg(self, R_body: np.ndarray, R_ground: np.ndarray) -> float:
        return math.degrees(math.acos(np.clip(R_body[2, 2], -1, 1)))

    def before_physics_step(self, t: float) -> None:
        """Before the physics step that ends at ``t``."""

    def report(self, tr: dict[str, np.ndarray]) -> dict:
        return {}


class SlipMeter:
    """How far each foot slides along the ground while it carries load, in the ground's own
    frame (the platform turns under the feet): the largest distance from where the foot took
    load in the same contact (a path length would add up contact jitter). The paper assumes
    no slipping; the low-friction scenario tests it."""

    def __init__(self, load_n: float):
        self.load_n = load_n
        self.anchor = np.full((6, 2), np.nan)
        self.slip_m = np.zeros(6)
        self.ratio_max = 0.0  # this step's largest tangential / normal force over the loaded feet

    def add(self, feet_w: np.ndarray, forces_w: np.ndarray, R_ground: np.ndarray) -> None:
        p = (feet_w @ R_ground)[:, :2]  # ground frame (its origin is on the hinge axis, the world origin)
        f = forces_w @ R_ground
        loaded = f[:, 2] > self.load_n
        self.ratio_max = float(np.max(np.hypot(f[loaded, 0], f[loaded, 1]) / f[loaded, 2])) if loaded.any() else 0.0
        new = loaded & np.isnan(self.anchor[:, 0])
        self.anchor[new] = p[new]
        self.anchor[~loaded] = np.nan
        d = np.linalg.norm(p - self.anchor, axis=1)
        self.slip_m = np.fmax(self.slip_m, np.where(loaded, d, 0.0))


class _Recorder:
    def __init__(self, n: int, nq: int, qpos: bool):
        self.rows: dict[str, list] = {k: [] for k in ("time_s", "platform_tilt_deg", "fasm_deg", "edge_leg_a", "edge_leg_b",
                                                      "ssm_m", "nesm_m", "foot_fz_n", "com_m", "tilt_rel_deg", "stance",
                                                      "qp_fz_n", "qp_stability", "feet_m", "foot_contact",
                                                      "foot_f_n", "qp_f_n", "friction_ratio")}
        self.qpos = qpos
        if qpos:
            self.rows["qpos"] = []
            self.rows["mocap_quat"] = []

    def add(self, t, tilt, mon: StepMonitor, forces_w, com, rel, ctl: TippingController, d, feet_w,
            friction_ratio: float = 0.0) -> None:
        r = self.rows
        r["friction_ratio"].append(friction_ratio)
        r["time_s"].append(t)
        r["platform_tilt_deg"].append(tilt)
        r["fasm_deg"].append(mon.margin_deg)
        r["edge_leg_a"].append(mon.edge_legs[0])
        r["edge_leg_b"].append(mon.edge_legs[1])
        r["ssm_m"].append(mon.ssm_m)
        r["nesm_m"].append(mon.nesm_m)
        r["foot_fz_n"].append(forces_w[:, 2].copy())
        r["com_m"].append(com.copy())
        r["tilt_rel_deg"].append(rel)
        r["stance"].append(np.array([leg in ctl.stance for leg in LEG_IDS]))
        r["qp_fz_n"].append(np.array([ctl.qp_forces.get(leg, np.zeros(3))[2] for leg in LEG_IDS]))
        r["qp_stability"].append(bool(ctl.qp_stability))
        r["foot_f_n"].append(forces_w.copy())
        r["qp_f_n"].append(np.array([ctl.qp_forces.get(leg, np.zeros(3)) for leg in LEG_IDS]))
        r["feet_m"].append(feet_w.copy())
        r["foot_contact"].append(forces_w[:, 2] > 0.02 * ctl.sim.mass * 9.81)
        if self.qpos:
            r["qpos"].append(d.qpos.copy())

    def finish(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.rows.items()}


def _physics_interval(world: _World, t: float, n_sub: int) -> np.ndarray:
    """The physics over one control interval from ``t``; the force sensors report the mean
    over the interval (50 Hz sampling), not its last step."""
    sim = world.sim
    m, d = sim.model, sim.data
    forces = np.zeros((6, 3))
    for j in range(n_sub):
        world.before_physics_step(t + (j + 1) * m.opt.timestep)
        mujoco.mj_step(m, d)
        forces += sim.foot_forces()
    forces /= n_sub
    mujoco.mj_forward(m, d)
    return forces


def _simulate(world: _World, cfg: ControllerConfig, duration_s: float, record_qpos: bool) -> dict:
    """The judgment-and-recovery controller every control step until the end of the run,
    or ``AFTER_TIP_S`` after the robot tipped over."""
    sim = world.sim
    m, d = sim.model, sim.data
    sim.place_feet(world.targets)
    ctl = TippingController(sim, cfg, world.stance, ground_check=world.ground_check)
    n_sub = max(1, int(round(cfg.control_dt / m.opt.timestep)))
    n_ctl = world.control_steps(int(round(duration_s / cfg.control_dt)), cfg.control_dt)
    rec = _Recorder(n_ctl, m.nq, record_qpos)
    slip = SlipMeter(0.02 * sim.mass * 9.81)
    tipped_at, control_s = None, []
    mujoco.mj_forward(m, d)
    forces_avg = sim.foot_forces()
    for k in range(n_ctl):
        t = k * cfg.control_dt
        world.before_control(t, ctl)
        for leg in LEG_IDS:
            if (world.drives_stance or leg not in ctl.stance) and (ctl.swing is None or ctl.swing[0] != leg):
                sim.set_foot_target(leg, world.targets[leg])
        feet_w, com = sim.feet_world(), sim.com()
        c0 = time.perf_counter()
        if t >= world.control_from_s:
            mon = ctl.step(t, feet_w, forces_avg, com)
        else:
            mon = monitor(feet_w, forces_avg, com, ctl.stance)
        control_s.append(time.perf_counter() - c0)
        R_ground = world.ground_rotation()
        if tipped_at is None:
            slip.add(feet_w, forces_avg, R_ground)
        rel = world.body_tilt_deg(sim.body_pose()[1], R_ground)
        rec.add(t, world.platform_tilt_deg(t), mon, forces_avg, com, rel, ctl, d, feet_w, slip.ratio_max)
        if rel > TIPPED_DEG and tipped_at is None:
            tipped_at = t
        if tipped_at is not None and t > tipped_at + AFTER_TIP_S:
            break
        forces_avg = _physics_interval(world, t, n_sub)
    tr = rec.finish()
    return {"trace": tr, "adjustments": [a.as_dict() for a in ctl.adjustments], "tipped": tipped_at is not None,
            "tipped_at_s": tipped_at, **world.report(tr), "max_slip_m": float(slip.slip_m.max()),
            "slip_m": slip.slip_m.tolist(), "control_ms_mean": 1e3 * float(np.mean(control_s)),
            "control_ms_p95": 1e3 * float(np.percentile(control_s, 95)), "model_xml": sim.spec.to_xml(),
            "sim_steps": len(tr["time_s"]) * n_sub, "mass_kg": sim.mass, "final_stance": list(ctl.stance)}


# -- tilting platform -----------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class TiltScenario:
    """The platform turns so that ``downhill_deg`` (0 = the robot's front, 90 = its left)
    goes down, at ``rate_deg_s`` after ``settle_s``, to the fixed final tilt ``max_tilt_deg``
    and holds it (Sec. 5.2: the Stewart platform rotates; the motion never looks at the
    robot, so whether the robot tips is an outcome, not a setting)."""

    downhill_deg: float = 180.0
    stance: tuple[int, ...] = (1, 3, 5)
    rate_deg_s: float = 10.0
    settle_s: float = 3.0
    max_tilt_deg: float = 40.0
    hold_s: float = 6.0  # the run lasts at least until the platform has held its final tilt this long
    lift_m: float = 0.45


def paper_direction(axis: str, direction: str) -> float:
    """Map the paper's platform rotations to the downhill direction. Seen from the axis's
    negative end, "ccw" about y raises the front (climbing, the robot tips backward) and
    "ccw" about x raises the right side (the robot tips to its left), as in Sec. 5.2."""
    table = {("y", "ccw"): 180.0, ("y", "cw"): 0.0, ("x", "ccw"): 90.0, ("x", "cw"): 270.0}
    return table[(axis, direction)]


def static_tip_angle(poly_xy: np.ndarray, com_xy: np.ndarray, height: float, downhill_deg: float) -> float:
    """Tilt (deg) at which the CoM's projection along the platform normal leaves the convex
    polygon ``poly_xy`` (CCW) travelling in the downhill direction."""
    d = np.array([math.cos(math.radians(downhill_deg)), math.sin(math.radians(downhill_deg))])
    best = np.inf
    n = len(poly_xy)
    for i in range(n):
        p, q = poly_xy[i], poly_xy[(i + 1) % n]
        e = q - p
        den = d[0] * e[1] - d[1] * e[0]
        if abs(den) < 1e-12:
            continue
        w = p - com_xy
        s = (w[0] * e[1] - w[1] * e[0]) / den
        u = (w[0] * d[1] - w[1] * d[0]) / den
        if s > 0 and -1e-9 <= u <= 1 + 1e-9:
            best = min(best, s)
    return math.degrees(math.atan2(best, height))


class _TiltWorld(_World):
    """The tilting platform: it turns under the standing robot along a fixed profile that
    never looks at the robot."""

    drives_stance = False  # the stance feet stand where they were put; only the lifted legs are held

    def __init__(self, scen: TiltScenario, g: HeavyHexapodGeometry):
        from app.robots.heavy_hexapod import build_tilt_spec

        psi = math.radians(scen.downhill_deg)
        axis = np.array([-math.sin(psi), math.cos(psi), 0.0])  # turning +angle about it lowers the downhill side
        sim = HexapodSim(build_tilt_spec(g, axis=tuple(axis)), g)
        stance = list(scen.stance)
        lift = np.array([0.0, 0.0, scen.lift_m])
        super().__init__(sim, {leg: g.nominal_foot(leg) + (0 if leg in stance else lift) for leg in LEG_IDS}, stance)
        self.scen, self.geom = scen, g
        self.control_from_s = scen.settle_s * 0.5
        self._platform = sim.model.body("platform").id
        self._servo = sim.model.actuator("tilt_servo").id
        self.tip_angle: float | None = None  # reported only: where the stance tripod would statically tip

    def control_steps(self, n_ctl: int, control_dt: float) -> int:
        s = self.scen  # long enough to reach the final tilt and hold it
        return max(n_ctl, int(round((s.settle_s + s.max_tilt_deg / s.rate_deg_s + 1.0 + s.hold_s) / control_dt)))

    def before_control(self, t: float, ctl: TippingController) -> None:
        if self.tip_angle is None and t >= self.scen.settle_s:  # the stance polygon as it stands, flat
            feet = self.sim.feet_world()[[l - 1 for l in self.stance]]
            com = self.sim.com()
            h = com[2] - feet[:, 2].mean() + self.geom.foot_radius
            order = ccw_order(feet)
            self.tip_angle = static_tip_angle(feet[order, :2], com[:2], h, self.scen.downhill_deg)

    def platform_tilt_deg(self, t: float) -> float:
        """Trapezoidal rate profile: 1 s ramps up to ``rate_deg_s`` and back down to rest at
        the final tilt (a rate step at either end would jolt a 5 t robot on a 20 t table)."""
        max_tilt = self.scen.max_tilt_deg
        s, R = t - self.scen.settle_s, self.scen.rate_deg_s
        ramp = min(1.0, max_tilt / R)
        total = max_tilt / R + ramp
        if s <= 0:
            return 0.0
        if s < ramp:
            return R * s * s / (2 * ramp)
        if s < total - ramp:
            return R * (s - ramp / 2)
        if s < total:
            return max_tilt - R * (total - s) ** 2 / (2 * ramp)
        return max_tilt

    def ground_rotation(self) -> np.ndarray:
        return self.sim.data.xmat[self._platform].reshape(3, 3)

    def body_tilt_deg(self, R_body: np.ndarray, R_ground: np.ndarray) -> float:
        return math.degrees(math.acos(np.clip(R_body[:, 2] @ R_ground[:, 2], -1, 1)))

    def before_physics_step(self, t: float) -> None:
        # The platform moves every physics step: a 20 ms jump would bounce the feet.
        self.sim.data.ctrl[self._servo] = math.radians(self.platform_tilt_deg(t))

    def report(self, tr: dict[str, np.ndarray]) -> dict:
        return {"static_tip_deg": self.tip_angle, "max_tilt_deg": self.scen.max_tilt_deg}


def run_tilt(scen: TiltScenario, cfg: ControllerConfig, duration_s: float, geom: HeavyHexapodGeometry = HEAVY,
             friction: float | None = None, record_qpos: bool = True) -> dict:
    return _simulate(_TiltWorld(scen, _with_friction(geom, friction)), cfg, duration_s, record_qpos)


# -- tripod walking onto a unilateral cliff ---------------------------------------------------

@dataclasses.dataclass(frozen=True)
class CliffScenario:
    """Tripod gait (Sec. 5.1: duty factor 14/24, step 0.5 m, period 6 s, 3 s standing first)
    along +x toward a cliff that cuts off the ground on one side at ``cliff_x``."""

    side: str = "right"
    cliff_x: float = 4.5
    drop_m: float = 3.0
    duty_factor: float = 14.0 / 24.0
    step_m: float = 0.5
    period_s: float = 6.0
    stand_s: float = 3.0
    lift_m: float = 0.3


def tripod_gait_targets(geom: HeavyHexapodGeometry, sc: CliffScenario, t: float) -> tuple[dict[int, np.ndarray], list[int]]:
    """Body-frame foot targets and the legs in stance at time t. Tripod {1,3,5} swings in
    the first (1 - beta) T of each period, {2,4,6} half a period later; the swing follows
    the quintic minimum-jerk profile with a lift bump, the stance moves back at constant
    speed. Before ``stand_s`` the pose of the gait's first instant is held."""
    T, beta = sc.period_s, sc.duty_factor
    t_sw = (1.0 - beta) * T
    tt = max(0.0, t - sc.stand_s)
    out, stance = {}, []
    for leg in LEG_IDS:
        off = 0.0 if leg in (1, 3, 5) else 0.5 * T
        tau = (tt - off) % T
        p = geom.nominal_foot(leg).copy()
        if tau < t_sw and t >= sc.stand_s:
            s = tau / t_sw
            p[0] += sc.step_m * (-0.5 + 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
            p[2] += sc.lift_m * 64.0 * s ** 3 * (1 - s) ** 3
        else:
            sig = (tau - t_sw) / (beta * T) if tau >= t_sw else 1.0  # standing: tripod 1-3-5 at the end of its stroke
            p[0] += sc.step_m * (0.5 - sig)
            stance.append(leg)
        out[leg] = p
    return out, stance


class _CliffWorld(_World):
    """Level ground cut off on one side: the tripod gait walks the robot toward the edge."""

    def __init__(self, sc: CliffScenario, g: HeavyHexapodGeometry):
        from app.robots.heavy_hexapod import build_cliff_spec

        # Walking on level ground needs no anti-creep friction, and with it (impratio 10) the
        # position-controlled stance tripod chatters (+-20 kN) as its feet sweep back together.
        g = dataclasses.replace(g, impratio=1.0, noslip_iterations=0)
        side = -1 if sc.side == "right" else 1
        sim = HexapodSim(build_cliff_spec(g, cliff_x=sc.cliff_x, side=side, drop=sc.drop_m), g)
        super().__init__(sim, *tripod_gait_targets(g, sc, 0.0))
        self.sc, self.geom = sc, g
        self._hit = np.zeros(1, np.int32)
        self._group = np.array([1, 0, 0, 0, 0, 0], np.uint8)

    def ground_check(self, p_world: np.ndarray) -> bool:
        m, d = self.sim.model, self.sim.data
        top = np.asarray(p_world, float) + [0.0, 0.0, 1.0]
        dist = mujoco.mj_ray(m, d, top, np.array([0.0, 0.0, -1.0]), self._group, 1, -1, self._hit)
        return 0 <= dist <= 1.6  # ground within 0.6 m under the foothold, not the void's floor

    def before_control(self, t: float, ctl: TippingController) -> None:
        if not ctl.frozen:  # a gait generator stops once a tip is detected
            self.targets, ctl.stance = tripod_gait_targets(self.geom, self.sc, t + ctl.cfg.control_dt)

    def report(self, tr: dict[str, np.ndarray]) -> dict:
        return {"distance_m": float(tr["com_m"][-1][0] - tr["com_m"][0][0])}


def run_cliff(sc: CliffScenario, cfg: ControllerConfig, duration_s: float, geom: HeavyHexapodGeometry = HEAVY,
              friction: float | None = None, record_qpos: bool = True) -> dict:
    return _simulate(_CliffWorld(sc, _with_friction(geom, friction)), cfg, duration_s, record_qpos)

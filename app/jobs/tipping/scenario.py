"""Tipping scenarios in MuJoCo (paper 002 Sec. 5): the tilting platform and tripod walking
onto a unilateral cliff, with the judgment-and-recovery controller running every control
step (0.02 s, the paper's sample time) on the simulated contact forces."""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np

from app.robots.heavy_hexapod import HEAVY, JOINT_NAMES, LEG_IDS, HeavyHexapodGeometry, joint_name
from app.jobs.tipping.stability.fast import distribute_fast, hull_ccw, margins, plane_normal
from app.jobs.tipping.stability.fasm import TipDetector
from app.jobs.tipping.stability.foothold import SwingPlan, leg_ik, optimal_foothold, reachable_space, select_adjustment_leg
from app.jobs.tipping.stability.polygon import ccw_order, fit_plane


@dataclasses.dataclass(frozen=True)
class ControllerConfig:
    recovery: bool = True
    threshold_deg: float = 20.0  # xi_f (Sec. 3)
    kappa: float = 0.8  # Eq. 15
    rho: float = 0.9  # safety margin of the reachable space (Eq. 11-13)
    lam: float = 0.9  # radius factor of the stability cone's base (Eq. 21)
    mu: float = 1.2  # friction the QP assumes; the QP's pyramid is inscribed in it
    parallel_deg: float = 15.0  # boundary-vs-axis angle under which L or R is taken (Sec. 4.2)
    # Swing time: "eq15" = the Eq. 15 time-to-tip, clipped to what the leg can do
    # [swing_min_s, swing_max_s]; "fixed" = always fixed_swing_s (the control that shows
    # whether the timing matters).
    swing_timing: str = "eq15"
    swing_min_s: float = 0.4
    swing_max_s: float = 4.0
    fixed_swing_s: float = 1.5
    clearance_m: float = 0.25
    press_m: float = 0.06  # target this far into the fitted ground so the foot surely lands
    min_lever_m: float = 0.05  # a swing leg that cannot reach this far outside the axis cannot help
    qp: bool = True
    control_dt: float = 0.02
    max_adjustments: int = 2
    # Stance control once the QP runs: "force" = the stance legs become compliant (servo
    # gains times ``compliance``, damping times its square root) about where they stand and
    # push the QP's forces through tau = -J^T f, so the feet carry the QP's distribution;
    # "position" = stiff servos with the QP only as feed-forward (the load then follows the
    # servos' stiffness, not the QP).
    stance_control: str = "force"
    compliance: float = 0.03
    # Posture feedback in the QP's target wrench b (Eq. 16's a_b and the moment): a critically
    # damped pull back to the body pose at the QP's takeover with this bandwidth (Hz); 0 =
    # off (b = support of gravity only), the default: the paper does not say what sets a_b.
    posture_hz: float = 0.0
    # The swing-hinge limit (deg) the foothold planner assumes; None: the robot's own (45 deg).
    # The paper's footholds (|y| 1.89-1.91 m in all six cases) are where the reach boundary R
    # lands with a limit near 30 deg: the `paper_reach` variant of `gaitmend reproduce tipping`.
    swing_max_deg: float | None = None


@dataclasses.dataclass
class Adjustment:
    detect_time_s: float
    margin_at_detection_deg: float
    edge_legs: tuple[int, int]
    time_to_tip_s: float
    margin_rate_deg_s: float
    margin_acc_deg_s2: float
    leg: int | None
    lever_arm_m: float = float("nan")
    foothold_label: str = ""
    foothold_body_m: list = dataclasses.field(default_factory=list)
    swing_s: float = float("nan")
    lands_before_tip: bool = False
    land_time_s: float | None = None
    margin_before_landing_deg: float = float("nan")
    margin_after_landing_deg: float = float("nan")

    def as_dict(self) -> dict:
        # JSON has no NaN: unknown numbers (no leg could help, never landed) become None.
        d = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in dataclasses.asdict(self).items()}
        d["time_to_tip_s"] = None if math.isinf(self.time_to_tip_s) else float(self.time_to_tip_s)
        d["lands_before_tip"] = bool(self.lands_before_tip)
        d["edge"] = edge_name(*self.edge_legs)
        d["adjustment_time_s"] = None if self.land_time_s is None else self.land_time_s - self.detect_time_s
        return d


# Tipped over: the body turned this far off the ground plane, i.e. it rotated about a
# support edge until something else hit the ground (the controlled robot stays within 3 deg).
TIPPED_DEG = 10.0
AFTER_TIP_S = 3.0  # keep simulating the fall this long, for the plots and the replay

PAPER_EDGES = ("a13", "a35", "a51", "a24", "a46", "a62")  # Table II's names


def planner_workspace(geom: HeavyHexapodGeometry, leg: int, cfg: ControllerConfig):
    """The leg's workspace as the foothold planner sees it: the robot's, with the swing
    limit lowered to ``cfg.swing_max_deg`` when that is set."""
    ws = geom.workspace(leg)
    if cfg.swing_max_deg is None:
        return ws
    return dataclasses.replace(ws, theta_range=(ws.theta_range[0], min(ws.theta_range[1], math.radians(cfg.swing_max_deg))))


def edge_name(i: int, j: int) -> str:
    """Support edge as Table II names it (its order for tripod 2-4-6 is clockwise)."""
    for name in (f"a{i}{j}", f"a{j}{i}"):
        if name in PAPER_EDGES:
            return name
    return f"a{i}{j}"


class HexapodSim:
    """Model, data and the per-step sensing the controller uses."""

    def __init__(self, spec: mujoco.MjSpec, geom: HeavyHexapodGeometry = HEAVY):
        self.spec = spec
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.geom = geom
        m = self.model
        self.torso = m.body("torso").id
        self.mass = float(m.body_subtreemass[self.torso])
        self.gravity = m.opt.gravity.copy()
        self.foot_geom = {leg: m.geom(f"leg{leg}_foot").id for leg in LEG_IDS}
        self.geom_leg = {g: leg for leg, g in self.foot_geom.items()}
        self.tip_site = {leg: m.site(f"leg{leg}_tip").id for leg in LEG_IDS}
        self.shank = {leg: m.body(f"leg{leg}_shank").id for leg in LEG_IDS}
        self.qadr = {leg: np.array([m.jnt_qposadr[m.joint(joint_name(leg, j)).id] for j in JOINT_NAMES]) for leg in LEG_IDS}
        self.dadr = {leg: np.array([m.jnt_dofadr[m.joint(joint_name(leg, j)).id] for j in JOINT_NAMES]) for leg in LEG_IDS}
        self.pid = {leg: np.array([m.actuator(f"{joint_name(leg, j)}_pid").id for j in JOINT_NAMES]) for leg in LEG_IDS}
        self.ff = {leg: np.array([m.actuator(f"{joint_name(leg, j)}_ff").id for j in JOINT_NAMES]) for leg in LEG_IDS}
        self.jlo = {leg: m.jnt_range[[m.joint(joint_name(leg, j)).id for j in JOINT_NAMES], 0] for leg in LEG_IDS}
        self.jhi = {leg: m.jnt_range[[m.joint(joint_name(leg, j)).id for j in JOINT_NAMES], 1] for leg in LEG_IDS}
        self._cf = np.zeros(6)
        self._kp0 = m.actuator_biasprm[:, 1].copy()  # pid actuators: bias = -kp (q - ctrl) - kv qdot
        self._kv0 = m.actuator_biasprm[:, 2].copy()
        self._jac = np.zeros((3, m.nv))
        self.root_dof = int(m.jnt_dofadr[m.joint("root").id])
        self.body_inertia = m.body_inertia[self.torso].copy()  # principal, about the torso's CoM

    # -- sensing ---------------------------------------------------------------------------
    def foot_forces(self) -> np.ndarray:
        """(6, 3) ground forces on each foot, world frame (3D contact-force sensors)."""
        d, out = self.data, np.zeros((6, 3))
        for i in range(d.ncon):
            c = d.contact[i]
            leg = self.geom_leg.get(c.geom2)
            sign = 1.0
            if leg is None:
                leg = self.geom_leg.get(c.geom1)
                sign = -1.0  # the normal points from geom1 to geom2
            if leg is None:
                continue
            mujoco.mj_contactForce(self.model, d, i, self._cf)
            out[leg - 1] += sign * (c.frame.reshape(3, 3).T @ self._cf[:3])
        return out

    def feet_world(self) -> np.ndarray:
        return np.stack([self.data.site_xpos[self.tip_site[leg]] for leg in LEG_IDS])

    def body_pose(self) -> tuple[np.ndarray, np.ndarray]:
        return self.data.xpos[self.torso].copy(), self.data.xmat[self.torso].reshape(3, 3).copy()

    def to_body(self, p_world: np.ndarray) -> np.ndarray:
        x, R = self.body_pose()
        return (np.asarray(p_world) - x) @ R

    def com(self) -> np.ndarray:
        return self.data.subtree_com[self.torso].copy()

    # -- actuation -------------------------------------------------------------------------
    def set_foot_target(self, leg: int, p_body: np.ndarray) -> None:
        x, dd, th = leg_ik(self.geom.workspace(leg), p_body)
        q = np.clip(np.array([th, x, dd]), self.jlo[leg], self.jhi[leg])
        self.data.ctrl[self.pid[leg]] = q

    def place_feet(self, feet_body: dict[int, np.ndarray]) -> None:
        """Put the joints at the targets before the first step (no start-up kick)."""
        for leg, p in feet_body.items():
            self.set_foot_target(leg, p)
            self.data.qpos[self.qadr[leg]] = self.data.ctrl[self.pid[leg]]
        mujoco.mj_forward(self.model, self.data)

    def set_compliance(self, leg: int, factor: float) -> None:
        """Scale this leg's servo stiffness by ``factor`` (damping by its square root, which
        keeps the damping ratio); 1 restores the stiff servo."""
        ids = self.pid[leg]
        self.model.actuator_biasprm[ids, 1] = self._kp0[ids] * factor
        self.model.actuator_biasprm[ids, 2] = self._kv0[ids] * math.sqrt(factor)

    def apply_foot_forces(self, forces: dict[int, np.ndarray]) -> None:
        """Feed-forward joint efforts so the stance legs push the QP's forces: tau = -J^T f."""
        self.data.ctrl[np.concatenate(list(self.ff.values()))] = 0.0
        for leg, f in forces.items():
            mujoco.mj_jac(self.model, self.data, self._jac, None, self.data.site_xpos[self.tip_site[leg]], self.shank[leg])
            tau = -(self._jac[:, self.dadr[leg]].T @ f)
            lo = self.model.actuator_ctrlrange[self.ff[leg], 0]
            hi = self.model.actuator_ctrlrange[self.ff[leg], 1]
            self.data.ctrl[self.ff[leg]] = np.clip(tau, lo, hi)


@dataclasses.dataclass
class StepMonitor:
    """FASM (and SSM, NESM beside it) over the current support polygon."""

    margin_deg: float
    edge_legs: tuple[int, int]
    ssm_m: float
    nesm_m: float
    edges_deg: np.ndarray
    polygon_legs: list[int]


def monitor(feet_w: np.ndarray, forces_w: np.ndarray, com: np.ndarray, stance: list[int]) -> StepMonitor:
    """The per-step margins on the scalar fast path (``app.jobs.tipping.stability.fast``, tested against
    the batched ``fasm_edges`` / ``ssm`` / ``nesm``). Gravity is world -z."""
    feet = feet_w.tolist()
    sub = [feet[l - 1] for l in stance]
    legs = [stance[i] for i in hull_ccw(sub)]
    th, s, e = margins(feet, forces_w.tolist(), com.tolist(), [l - 1 for l in legs])
    i = min(range(len(th)), key=th.__getitem__)
    return StepMonitor(margin_deg=th[i], edge_legs=(legs[i], legs[(i + 1) % len(legs)]), ssm_m=s, nesm_m=e,
                       edges_deg=np.asarray(th), polygon_legs=legs)


class TippingController:
    """Judgment every control step; on a tip, one adjustment leg swings (quintic) to the
    optimal foothold and joins the stance; the QP then distributes the stance forces."""

    def __init__(self, sim: HexapodSim, cfg: ControllerConfig, stance: list[int], ground_check=None):
        self.sim, self.cfg = sim, cfg
        self.ground_check = ground_check  # world point -> is there ground to stand on
        self.stance = list(stance)
        self.detector = TipDetector(threshold_deg=cfg.threshold_deg, kappa=cfg.kappa)
        self.adjustments: list[Adjustment] = []
        self.swing: tuple[int, SwingPlan, float, Adjustment] | None = None
        self.frozen = False  # a gait generator stops once a tip is detected
        self.prev_feet_body: np.ndarray | None = None
        self.qp_forces: dict[int, np.ndarray] = {}
        self.qp_stability = False
        self.pending_after: list[tuple[float, Adjustment]] = []
        self.hold_targets: dict[int, np.ndarray] = {}  # stance feet (body frame) when the QP took over
        self.posture_ref: tuple[np.ndarray, np.ndarray] | None = None

    def support(self, forces_w: np.ndarray) -> list[int]:
        """The support polygon's legs: those commanded to stance plus any foot carrying load
        (a lifting tripod unloads over a few steps, an adjustment foot loads as it lands;
        a force in Eq. 4 whose foot is left out of the polygon would read as a false tip)."""
        loaded = [leg for leg in LEG_IDS if forces_w[leg - 1, 2] > 0.02 * self.sim.mass * 9.81]
        return sorted(set(self.stance) | set(loaded))

    def step(self, t: float, feet_w: np.ndarray, forces_w: np.ndarray, com: np.ndarray) -> StepMonitor:
        sim, cfg = self.sim, self.cfg
        mon = monitor(feet_w, forces_w, com, self.support(forces_w))
        tipping = self.detector.update(t, mon.margin_deg)
        feet_b = sim.to_body(feet_w)
        for t_after, adj in list(self.pending_after):
            if t >= t_after:
                adj.margin_after_landing_deg = mon.margin_deg
                self.pending_after.remove((t_after, adj))
        if self.swing is not None:
            self._advance_swing(t, forces_w, mon)
        elif cfg.recovery and tipping and len(self.adjustments) < cfg.max_adjustments and len(self.detector.times) >= 3:
            self._start_adjustment(t, mon, feet_b)
        if cfg.recovery and cfg.qp and any(a.land_time_s is not None for a in self.adjustments):
            self._distribute(feet_w, forces_w, com)
        self.prev_feet_body = feet_b
        return mon

    def _start_adjustment(self, t: float, mon: StepMonitor, feet_b: np.ndarray) -> None:
        sim, cfg = self.sim, self.cfg
        v, a = self.detector.rates()
        adj = Adjustment(detect_time_s=t, margin_at_detection_deg=mon.margin_deg, edge_legs=mon.edge_legs,
                         time_to_tip_s=self.detector.time_to_tip(), margin_rate_deg_s=v, margin_acc_deg_s2=a, leg=None)
        self.frozen = True
        normal, origin = fit_plane(feet_b[[l - 1 for l in self.stance]])  # Sec. 4.2, body frame
        candidates = {leg: reachable_space(planner_workspace(sim.geom, leg, cfg), normal, origin, cfg.rho)
                      for leg in LEG_IDS if leg not in self.stance}
        p_i, p_j = feet_b[mon.edge_legs[0] - 1], feet_b[mon.edge_legs[1] - 1]
        self.adjustments.append(adj)
        while True:
            leg, lever = select_adjustment_leg((p_i, p_j), candidates)
            if leg is None or lever < cfg.min_lever_m:
                adj.lever_arm_m = lever
                self.detector.times.clear()  # judge again from fresh samples, not every step
                self.detector.margins.clear()
                return
            label, target, lever = optimal_foothold(candidates[leg], p_i, p_j, cfg.parallel_deg)
            if self.ground_check is None:
                break
            x, R = sim.body_pose()
            if self.ground_check(x + R @ target):
                break
            candidates[leg] = None  # its best foothold is over a void: the next leg
        adj.leg, adj.lever_arm_m, adj.foothold_label, adj.foothold_body_m = leg, lever, label, target.tolist()
        if cfg.swing_timing == "fixed":
            T = float(cfg.fixed_swing_s)
        else:
            T = float(np.clip(adj.time_to_tip_s, cfg.swing_min_s, cfg.swing_max_s))
        adj.swing_s, adj.lands_before_tip = T, T <= adj.time_to_tip_s
        p0 = feet_b[leg - 1]
        v0 = np.zeros(3) if self.prev_feet_body is None else (p0 - self.prev_feet_body[leg - 1]) / cfg.control_dt
        plan = SwingPlan.plan(p0, v0, np.zeros(3), target - cfg.press_m * normal, T, cfg.clearance_m, normal)
        self.swing = (leg, plan, t, adj)

    def _advance_swing(self, t: float, forces_w: np.ndarray, mon: StepMonitor) -> None:
        leg, plan, t0, adj = self.swing
        tau = t - t0
        self.sim.set_foot_target(leg, plan.at(tau + self.cfg.control_dt)[0])
        loaded = forces_w[leg - 1] @ np.array([0.0, 0.0, 1.0]) > 0.02 * self.sim.mass * 9.81
        if not loaded:  # the margin the moment before the foot takes load
            adj.margin_before_landing_deg = mon.margin_deg
        if tau >= plan.duration and (loaded or tau >= plan.duration + 1.0):
            adj.land_time_s = t
            self.stance.append(leg)
            self.swing = None
            self.pending_after.append((t + 0.5, adj))
            self.detector.times.clear()
            self.detector.margins.clear()

    def _distribute(self, feet_w: np.ndarray, forces_w: np.ndarray, com: np.ndarray) -> None:
        """QP forces (Eq. 16-24) on the stance legs. With ``stance_control == "force"`` each
        stance leg is made compliant about the foot position it had when the QP took it over
        and pushes the QP's force through tau = -J^T f, so the measured foot forces follow
        the QP (tested); with "position" the stiff servos stay and the QP is feed-forward only."""
        sim, cfg = self.sim, self.cfg
        pts = [feet_w[l - 1].tolist() for l in self.stance]
        x, R = sim.body_pose()
        normal = plane_normal(pts)
        acc, moment = self._posture_wrench(x, R)
        sol = distribute_fast(pts, com.tolist(), sim.mass, tuple(sim.gravity), normal=normal, mu=cfg.mu,
                              lam=cfg.lam, body_x=tuple(R[:, 0]), acc=acc, moment=moment)
        self.qp_forces = {l: sol.forces[i] for i, l in enumerate(self.stance)}
        self.qp_stability = sol.stability_constrained
        sim.apply_foot_forces(self.qp_forces)
        if cfg.stance_control != "force":
            return
        for leg in self.stance:
            if leg not in self.hold_targets:
                self.hold_targets[leg] = (feet_w[leg - 1] - x) @ R
                sim.set_compliance(leg, cfg.compliance)
            sim.set_foot_target(leg, self.hold_targets[leg])


    def _posture_wrench(self, x: np.ndarray, R: np.ndarray) -> tuple[tuple, tuple]:
        """Desired body acceleration and moment (world frame) pulling the body back to its
        pose at the QP's takeover, critically damped at ``posture_hz``."""
        if self.cfg.posture_hz <= 0:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if self.posture_ref is None:
            self.posture_ref = (x.copy(), R.copy())
        x0, R0 = self.posture_ref
        wn = 2.0 * math.pi * self.cfg.posture_hz
        qv = self.sim.data.qvel[self.sim.root_dof:self.sim.root_dof + 6]
        acc = -wn * wn * (x - x0) - 2.0 * wn * qv[:3]  # free joint: linear velocity in the world frame
        E = R @ R0.T
        ang = math.acos(max(-1.0, min(1.0, 0.5 * (np.trace(E) - 1.0))))
        axis = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
        rot = axis * (0.5 * ang / math.sin(ang)) if ang > 1e-9 else 0.5 * axis
        w = R @ qv[3:]  # angular velocity: the free joint's is in the body frame
        inertia = R @ np.diag(self.sim.body_inertia) @ R.T
        moment = inertia @ (-wn * wn * rot - 2.0 * wn * w)
        return tuple(acc), tuple(moment)


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

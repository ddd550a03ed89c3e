"""The judgment-and-recovery controller of paper 002 (Sec. 3-4), as the tipping scenarios
run it every control step (0.02 s, the paper's sample time): its settings
(``ControllerConfig``), the margins it judges on (``monitor``), the record of each
adjustment it makes, and ``TippingController`` (detect a tip, swing one leg to the
optimal foothold, distribute the stance forces by the QP). app/jobs/tipping/scenario.py
runs it on the simulated robot (app/jobs/tipping/hexapod_sim.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.robots.heavy_hexapod import LEG_IDS, HeavyHexapodGeometry
from app.jobs.tipping.hexapod_sim import HexapodSim
from app.jobs.tipping.stability.fast import distribute_fast, hull_ccw, margins, plane_normal
from app.jobs.tipping.stability.fasm import TipDetector
from app.jobs.tipping.stability.foothold import SwingPlan, optimal_foothold, reachable_space, select_adjustment_leg
from app.jobs.tipping.stability.polygon import fit_plane


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

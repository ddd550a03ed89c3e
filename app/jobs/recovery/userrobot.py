"""The recovery job on an uploaded robot (issue 23): a stored MJCF model with its leg map,
damaged by the map's leg and joint names.

The service hands the job the stored robot (``RunContext.load_robot``: the worker reads the
sanitised model from the store, ``gaitmend run`` from this machine's store); this module
turns it into what the recovery job's steps read of a robot (``UserRobot``, in the form of
``RobotEntry``) and sets the job up (``set_up``), the rest of the job unchanged.

- **Geometry.** At the leg map's stance (else the model's reference pose, clipped to the
  joint ranges) each leg's hip is its first joint's anchor; the stance height H is the mean
  height of the hips above the feet. Eq. 3's hip frame of a leg is x outward (the trunk's
  left for a left leg, its right for a right one), y forward (the map's ``forward``), z up,
  at the hip's place over the trunk and at the hips' mean height. The nominal x0 is the
  legs' mean outward foot offset, each leg's nominal y0 its forward foot offset.
- **Search space** (the JetHexa's Sec. IV-B bounds scaled by H / 0.10 m): y0 within
  +-0.3 H of each leg's nominal, x0 within +-0.2 H of the nominal, step length 0.2-0.5 H
  (nominal 0.4 H), step height 0.2-0.5 H (nominal 0.3 H); a neighbour of a lost leg gets
  its y0 range widened by ``bounds.neighbour_relaxation`` as on the built-in robot.
- **Gait sequences** from the general planner (``plan_general``) for the legs left, with
  the neighbours of the leg map (the legs next in order on the same side and the leg of
  the same rank on the other side); the baseline is the intact robot's planned sequence
  with the nominal parameters, on the damaged robot. Fewer than four legs, or none left on
  a side, is refused (a three-legged static gait needs another planner).
- **Joint targets.** One gait period of foot targets for the whole population goes through
  the batched numerical IK (app/robots/numik.py) on the damaged model (locked joints gone,
  passive joints held at their stance value in the IK); every answer's error comes from
  forward kinematics of the answer and the worst is reported (``ik`` in the summary).
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np

from app.jobs.recovery.gait_controller import trunk_targets
from app.jobs.recovery.sequences import GaitSequence, InfeasibleMorphology, plan_general
from app.jobs.recovery.trajectory import bounds_of, stance_box, tip_positions
from app.robots.legmap import LegMap, LegMapError, Robot
from app.robots.numik import LegIK
from app.robots.damage import Damage
from app.robots.walkable import Walkable, heading_quat, leg_numbers, make_walkable

JETHEXA_STANCE_M = 0.10  # the built-in robot's H, to which its bounds (and the closed loop's metres) belong
IK_TOL, IK_MAX_ITER = 1e-7, 30  # every joint set-point: the numerical IK's tolerance (m) and iterations


@dataclasses.dataclass(frozen=True)
class _Side:
    side: int  # -1 left, +1 right (the built-in's convention)


@dataclasses.dataclass(frozen=True)
class UserGeometry:
    """What the evaluator and the robustness cases read of a robot's geometry."""

    foot_radius: float
    total_mass: float
    sides: dict[int, int]

    def leg(self, n: int) -> _Side:
        return _Side(self.sides[n])


@dataclasses.dataclass
class Nominal:
    """The intact robot's stance in Eq. 3's terms (see the module doc), legs by number."""

    origin: dict[int, np.ndarray]  # hip frame origin in the trunk frame
    outward: dict[int, np.ndarray]
    forward: np.ndarray
    up: np.ndarray
    stance_height: float
    x0: float
    y0: dict[int, float]
    feet_xy: dict[int, tuple[float, float]]  # (outward-signed lateral, forward) for support polygons


def neighbours_of(legs: LegMap) -> dict[int, set[int]]:
    """Leg number -> the legs next to it in order on its side and of its rank on the other."""
    num = leg_numbers(legs)
    ranks = {s: sorted((l for l in legs.legs if l.side == s), key=lambda l: l.order) for s in ("left", "right")}
    out: dict[int, set[int]] = {n: set() for n in num.values()}
    for side, row in ranks.items():
        other = ranks["right" if side == "left" else "left"]
        for k, leg in enumerate(row):
            near = [row[i] for i in (k - 1, k + 1) if 0 <= i < len(row)] + ([other[k]] if k < len(other) else [])
            out[num[leg.name]] |= {num[l.name] for l in near}
    return out


STANDS = 0.3  # a rest pose stands when its hips are this many leg reaches above its feet


def standing_pose(ik: LegIK, legs: LegMap) -> np.ndarray:
    """The stance's joint values: the leg map's where it gives them; else the reference
    pose when it stands (hips at least STANDS reaches above the feet); else each foot put
    by the IK half a reach below its hip, 0.7 reach out along its rest direction."""
    hips = np.array([c.kinematics(ik.q_ref[None, s])[2][0, 0] for c, s in zip(ik.chains, ik.cols)])
    feet = ik.fk(ik.q_ref)
    reach = np.linalg.norm(feet - hips, axis=-1)
    if all(l.stance is not None for l in legs.legs) or np.mean(hips[:, 2] - feet[:, 2]) >= STANDS * np.mean(reach):
        return ik.q_ref.copy()
    flat = (feet - hips) * np.array([1.0, 1.0, 0.0])
    flat /= np.maximum(np.linalg.norm(flat, axis=-1, keepdims=True), 1e-9)
    target = hips + 0.7 * reach[:, None] * flat - 0.5 * reach[:, None] * np.array([0.0, 0.0, 1.0])
    return ik.solve(target).q


def nominal_stance(robot: Robot) -> tuple[Nominal, dict[str, float]]:
    """From the intact model at the stance (module doc), and the stance's joint values by
    name; LegMapError when it does not stand."""
    legs = robot.legs
    model = robot.model()
    ik = LegIK(model, legs)
    ik.q_ref = standing_pose(ik, legs)
    num = leg_numbers(legs)
    fwd, left = np.array(legs.forward_vector()), np.array(legs.left_vector())
    up = np.array([0.0, 0.0, 1.0])
    hips, feet = {}, {}
    stance_feet = ik.fk(ik.q_ref)
    for i, (leg, chain, s) in enumerate(zip(legs.legs, ik.chains, ik.cols)):
        hips[num[leg.name]] = chain.kinematics(ik.q_ref[None, s])[2][0, 0]
        feet[num[leg.name]] = stance_feet[i]
    H = float(np.mean([hips[n][2] - feet[n][2] for n in hips]))
    reach = float(np.mean([np.linalg.norm(feet[n] - hips[n]) for n in hips]))
    if not H > 0.05 * reach:
        raise LegMapError(f"the stance does not stand: the feet are {H:.3f} m below the hips (reach {reach:.3f} m); "
                          "give each leg's stance joint values in the leg map")
    zh = float(np.mean([hips[n][2] for n in hips]))
    sides = {num[l.name]: (-1 if l.side == "left" else 1) for l in legs.legs}
    origin = {n: np.array([h[0], h[1], zh]) for n, h in hips.items()}
    outward = {n: -sides[n] * left for n in hips}
    x0 = float(np.mean([(feet[n] - origin[n]) @ outward[n] for n in hips]))
    y0 = {n: float((feet[n] - origin[n]) @ fwd) for n in hips}
    feet_xy = {n: (float(feet[n] @ -left), float(feet[n] @ fwd)) for n in hips}
    return Nominal(origin, outward, fwd, up, H, x0, y0, feet_xy), dict(zip(legs.joint_names(), map(float, ik.q_ref)))


def check_standing(legs: LegMap, functional: list[int]) -> None:
    """At least four legs and one on each side, else InfeasibleMorphology saying so."""
    num = leg_numbers(legs)
    side = {num[l.name]: l.side for l in legs.legs}
    n_left = sum(1 for n in functional if side[n] == "left")
    n_right = len(functional) - n_left
    if len(functional) < 4 or not n_left or not n_right:
        raise InfeasibleMorphology(
            f"infeasible morphology: {len(functional)} legs left ({n_left} left, {n_right} right); a static gait "
            "needs at least 4 legs with one on each side (a three-legged gait needs another planner)")


class UserRobot:
    """A stored robot under one damage, in the form the recovery job reads of a robot
    (``RobotEntry``'s names), with its own leg layout and IK for the evaluator
    (``gait_layout``, app/jobs/recovery/evaluate.py)."""

    def __init__(self, robot_id: str, robot: Robot, damage: Damage, timestep: float | None = None):
        self.name = robot_id
        self.robot = robot
        self.nominal, self.stance = nominal_stance(robot)
        self.walk: Walkable = make_walkable(robot, damage, timestep)
        self.numbers = self.walk.numbers  # the legs left
        num = leg_numbers(robot.legs)
        self.all_legs = sorted(num.values())
        sides = {num[l.name]: (-1 if l.side == "left" else 1) for l in robot.legs.legs}
        self.geometry = UserGeometry(self.walk.foot_radius, self.walk.total_mass, sides)
        H = self.nominal.stance_height
        self.stance_height = H
        self.nominal_step_length, self.nominal_step_height = 0.4 * H, 0.3 * H
        self.box = stance_box(self.nominal.x0, self.nominal.y0, H)
        self.ik: LegIK | None = None
        self._chains: dict[tuple[int, ...], dict] = {}  # controller_chain's, by leg order
        self.ik_stats = {"calls": 0, "wall_s": 0.0, "targets": 0, "max_error_m": 0.0, "beyond_1mm": 0}

    # -- RobotEntry's names -----------------------------------------------------------------
    def nominal_y0(self, leg: int) -> float:
        return self.nominal.y0[leg]

    def nominal_x0(self) -> float:
        return self.nominal.x0

    def nominal_feet_xy(self) -> dict[int, tuple[float, float]]:
        """Foot positions (right, forward) in the trunk's frame at the stance."""
        return self.nominal.feet_xy

    def model(self) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
        return self.walk.spec, self.walk.spec.compile()

    def legs_left(self) -> list[int]:
        return sorted(self.numbers.values())

    # -- the evaluator's legs ---------------------------------------------------------------
    def gait_layout(self, ev, model: mujoco.MjModel, cfg) -> None:
        """Sets the evaluator's side signs, ctrl columns (one per IK joint, -1 for a passive
        one), first orientation and standing height, and its joint_targets."""
        if self.ik is None:
            self.ik = self._damaged_ik(model)
        free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
        if len(free) != 1 or model.jnt_qposadr[free[0]] != 0:
            raise ValueError("the trunk's free joint must be the model's first joint")
        ev.sides = np.array([self.geometry.sides[n] for n in ev.legs])
        acts = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a): a for a in range(model.nu)}
        ev.ctrl_cols = np.array([acts.get(f"{j}_servo", -1) for j in self._joint_order(ev.legs)])
        q = np.zeros(4)
        mujoco.mju_negQuat(q, heading_quat(self.robot.legs))
        ev.root_quat = tuple(float(v) for v in q)
        feet_z = [self.nominal.origin[n][2] - self.stance_height for n in ev.legs]
        ev.torso_height0 = -float(np.mean(feet_z)) + self.geometry.foot_radius + 0.002
        ev.min_height = 0.5 * ev.torso_height0
        ev.joint_targets = lambda params: self.joint_targets(ev, params)
        ev.controller_chain = self.controller_chain(ev.legs)
        ev.controller_heading = heading_quat(self.robot.legs).tolist()  # the gait's frame in the trunk's

    def frames(self, legs: list[int]) -> dict:
        """The hip frames of ``legs`` (numbers, in that order) in the trunk's frame, as
        gait_controller.trunk_targets reads them."""
        nom = self.nominal
        return {"origin": np.array([nom.origin[n] for n in legs]), "outward": np.array([nom.outward[n] for n in legs]),
                "forward": np.asarray(nom.forward), "up": np.asarray(nom.up)}

    def controller_chain(self, legs: list[int]) -> dict:
        """What the closed-loop controller (gait_controller.GaitController ``chain``) needs to
        turn tips of ``legs`` into joint set-points as ``joint_targets`` does: their frames
        and the damaged robot's numerical IK, its legs in that order (JSON-able)."""
        key = tuple(legs)
        if key not in self._chains:  # one per leg order: every evaluator of the job asks for the same
            order = [self.numbers[l.name] for l in self.walk.legs.legs]  # the IK's leg order
            f = self.frames(legs)
            self._chains[key] = {"frames": {k: np.asarray(v).tolist() for k, v in f.items()},
                                 "solver": self.ik.subset([order.index(n) for n in legs]).as_dict(), "tol": IK_TOL,
                                 "max_iter": IK_MAX_ITER}
        return self._chains[key]

    def _damaged_ik(self, model: mujoco.MjModel) -> LegIK:
        ik = LegIK(model, self.walk.legs)
        names = self.walk.legs.joint_names()
        ik.q_ref = np.clip(np.array([self.stance[j] for j in names]), ik.lo, ik.hi)
        for leg, joints in self.walk.passive.items():
            for j in joints:  # unpowered: the IK leaves it at its stance value
                k = names.index(j)
                ik.lo[k] = ik.hi[k] = ik.q_ref[k]
        return ik

    def _joint_order(self, legs: list[int]) -> list[str]:
        by_num = {self.numbers[l.name]: l for l in self.walk.legs.legs}
        return [j for n in legs for j in by_num[n].joints]

    def joint_targets(self, ev, params: np.ndarray) -> np.ndarray:
        """Joint set-points (P, n_period, joints of ev.legs) over one gait period: Eq. 3's
        tips in each hip frame, to the trunk frame, through the numerical IK."""
        t = np.arange(ev.n_period) * ev.dt
        tips = tip_positions(params, ev.legs, ev.seq, t, ev.n_period * ev.dt, ev.cfg.stance_height_m,
                             ev.cfg.step_depth_m)
        order = [self.numbers[l.name] for l in self.walk.legs.legs]  # the IK's leg order
        target = trunk_targets(tips[..., [ev.legs.index(n) for n in order], :], self.frames(order))
        t0 = time.perf_counter()
        res = self.ik.solve(target, tol=IK_TOL, max_iter=IK_MAX_ITER)
        s = self.ik_stats
        s["calls"] += 1
        took = time.perf_counter() - t0
        s["wall_s"] += took
        if res.err.size >= s.get("population_targets", 0):  # the largest call: a whole population's period
            s["population_targets"], s["population_wall_s"] = int(res.err.size), took
        s["targets"] += int(res.err.size)
        s["max_error_m"] = max(s["max_error_m"], float(res.err.max()))
        worst = res.err.reshape(-1, res.err.shape[-1]).max(axis=0)
        by_leg = s.setdefault("max_error_m_by_leg", {})
        for leg, e in zip(self.walk.legs.legs, worst):
            by_leg[leg.name] = max(by_leg.get(leg.name, 0.0), float(e))
        s["beyond_1mm"] += int(np.sum(res.err > 1e-3))
        cols = np.cumsum([0] + [len(l.joints) for l in self.walk.legs.legs])
        parts = {n: res.q[..., cols[i]:cols[i + 1]] for i, n in enumerate(order)}
        return np.concatenate([parts[n] for n in ev.legs], axis=-1)

    def summary(self) -> dict:
        """What the job's summary says of the robot: legs, stance, gains, actuation, IK."""
        w = self.walk
        calls = max(self.ik_stats["calls"], 1)
        return {"legs": {name: n for name, n in sorted(w.numbers.items(), key=lambda kv: kv[1])},
                "stance_height_m": self.stance_height, "total_mass_kg": w.total_mass,
                "actuation": {"used": "position servos (pid actuator on each driven leg joint)",
                              "upload_had": w.upload_actuators or {"none": 0}, "gains": w.gains,
                              "passive_joints": {k: v for k, v in w.passive.items() if v}},
                "ik": self.ik_stats | {"per_call_wall_s": self.ik_stats["wall_s"] / calls}}  # clock: verify skips


def named_damage(spec) -> Damage:
    """An uploaded robot's damage: the spec's ``robot_damage`` (the robot layer's vocabulary), else none."""
    return spec.robot_damage or Damage()


def search_bounds(spec, robot: UserRobot, legs: list[int], lost: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """X_min / X_max in the layout of ``param_names`` (module doc); the spec's bounds win."""
    near = neighbours_of(robot.robot.legs)
    return bounds_of(spec.bounds, robot, legs, {n for l in lost for n in near[l]} - set(lost))


def plan(robot: UserRobot, model: mujoco.MjModel, legs: list[int], name: str) -> GaitSequence:
    """The general planner's sequence for ``legs`` (its support polygons around the
    damaged robot's centre of mass at the reference pose)."""
    check_standing(robot.robot.legs, legs)
    near = neighbours_of(robot.robot.legs)
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    mujoco.mj_comPos(model, d)
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot.walk.legs.trunk)
    R = d.xmat[trunk].reshape(3, 3)
    com = R.T @ (d.subtree_com[trunk] - d.xpos[trunk])
    left, fwd = np.array(robot.robot.legs.left_vector()), robot.nominal.forward
    return plan_general(legs, robot.nominal.feet_xy, lambda l: near[l], (float(com @ -left), float(com @ fwd)),
                        name=name)


def set_up(spec, stored: Robot, job_class, scorer):
    """The recovery job's state for an uploaded robot: ``job_class`` and ``scorer`` are
    run.py's ``_Job`` and ``scorer`` (passed in: run.py imports this module)."""
    from app.jobs.recovery.cases import walking_cases
    from app.jobs.recovery.closedloop import law_of
    from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
    from app.jobs.recovery.robust import MultiModelEvaluator, case_models
    from app.jobs.recovery.trajectory import param_names

    robot = UserRobot(spec.robot, stored, named_damage(spec), spec.sim.timestep_s)
    mspec, model = robot.model()
    mspec.option.timestep = spec.sim.timestep_s
    model = mspec.compile()
    legs = robot.legs_left()
    lost = [n for n in robot.all_legs if n not in legs]
    seq = plan(robot, model, legs, "general")
    base_seq = plan(robot, model, robot.all_legs, "intact_plan")
    base_seq = GaitSequence("intact_plan", base_seq.sigma, {l: p for l, p in base_seq.swing_phase.items() if l in legs})
    lower, upper = search_bounds(spec, robot, legs, lost)
    law = law_of(spec.control, (lower[-2], upper[-2]), scale=robot.stance_height / JETHEXA_STANCE_M)
    cfg = SimConfig(duration_s=spec.sim.duration_s, settle_s=spec.sim.settle_s, period_s=spec.gait.period_s,
                    stance_height_m=robot.stance_height, step_depth_m=spec.gait.step_depth_m, law=law)
    cases = walking_cases(robot.geometry.total_mass, spec.robustness.cases)  # the trunk is "torso" (walkable.py)
    return job_class(spec=spec, robot=robot, mspec=mspec, model=model, legs=legs, seq=seq, lower=lower, upper=upper,
                     names=param_names(legs), score=scorer(spec, robot, mspec, model, seq, cfg),
                     ev=GaitEvaluator(robot, model, seq, cfg), base_ev=GaitEvaluator(robot, model, base_seq, cfg),
                     cases=cases,
                     rob_ev=MultiModelEvaluator(robot, case_models(mspec, model, cases), seq, cfg) if cases else None)


def spec_error(spec, legs_json: dict) -> str | None:
    """Why ``spec`` cannot run on a robot of this leg map (JSON), checked before queueing:
    names the map lacks, too few legs left, a lock that cannot be made; None when it can."""
    try:
        legs = LegMap.parse(legs_json)
        damage = named_damage(spec)
        damage.check(legs)
        num = leg_numbers(legs)
        check_standing(legs, sorted(n for name, n in num.items() if name not in damage.lost_legs))
    except (LegMapError, InfeasibleMorphology) as e:
        return f"robot_damage: {e}"
    return None

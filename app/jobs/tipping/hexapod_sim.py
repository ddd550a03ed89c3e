"""The simulated heavy hexapod as the tipping controller senses and drives it: the compiled
MuJoCo model, the feet's contact forces and positions, the body pose and centre of mass,
and the servo targets, compliance and feed-forward efforts it commands."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from app.robots.heavy_hexapod import HEAVY, JOINT_NAMES, LEG_IDS, HeavyHexapodGeometry, joint_name
from app.jobs.tipping.stability.foothold import leg_ik


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

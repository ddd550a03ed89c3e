"""The built-in JetHexa's catalog entry (app/robots/catalog.py registers it): its builder
(this folder's __init__.py), nominal stance and gait; and ``RobotEntry``, what a built-in
3-DoF hexapod answers (its leg map, model under a damage, stance, description). The
recovery kind's search bounds around the stance are the kind's
(app/jobs/recovery/trajectory.py)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import mujoco

from app.robots import hexapod
from app.robots.contacts import explicit_pairs
from app.robots.damage import Damage, DamageSpec, apply_damage
from app.robots.legmap import LegMap, Robot


@dataclasses.dataclass(frozen=True)
class RobotEntry:
    name: str
    description: str
    geometry: hexapod.HexapodGeometry
    build: Callable[[], mujoco.MjSpec]
    legs: tuple[int, ...]
    joints: tuple[str, ...]
    # Nominal stance (body frame, m): each foot's reach x0 out from its hip and lateral
    # offset y0 (forward positive on the right side), as a designer would set them.
    x0: float
    y0: dict[int, float]
    # Nominal healthy gait.
    nominal_step_length: float
    nominal_step_height: float
    stance_height: float  # H0: hip plane above the foot centres
    period_s: float  # T_g; the paper does not give it (docs/recovery.md, "Choices where the paper is silent")

    def nominal_y0(self, leg: int) -> float:
        return self.y0[leg]

    def nominal_x0(self) -> float:
        return self.x0

    def nominal_feet_xy(self) -> dict[int, tuple[float, float]]:
        """Foot positions in the body frame at the nominal stance, for support polygons."""
        out = {}
        for lg in self.geometry.legs():
            hx, hy, _ = lg.hip
            out[lg.leg] = (hx + lg.side * self.nominal_x0(), hy + self.nominal_y0(lg.leg))
        return out

    def stance_com_xy(self, model: mujoco.MjModel, stance_height: float) -> tuple[float, float]:
        """Centre of mass (body frame, xy) of a (damaged) model standing at the nominal
        stance: what the gait planner's support polygons must hold."""
        import numpy as np

        from app.robots.ik import leg_ik

        data = mujoco.MjData(model)
        data.qpos[3] = 1.0
        for lg in self.geometry.legs():
            tip = np.array([self.nominal_x0(), lg.side * self.nominal_y0(lg.leg), -stance_height])
            q = leg_ik(tip, self.geometry.link_lengths)
            for jn, v in zip(hexapod.JOINT_NAMES, q):
                jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, hexapod.joint_name(lg.leg, jn))
                if jid >= 0:
                    data.qpos[model.jnt_qposadr[jid]] = v
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        return float(data.subtree_com[torso, 0]), float(data.subtree_com[torso, 1])

    def nominal_stance(self) -> dict[int, list[float]]:
        """Joint angles of each leg at the nominal stance (foot at x0, y0, H0 below the hip)."""
        import numpy as np

        from app.robots.ik import leg_ik

        out = {}
        for lg in self.geometry.legs():
            tip = np.array([self.nominal_x0(), lg.side * self.nominal_y0(lg.leg), -self.stance_height])
            out[lg.leg] = [float(v) for v in leg_ik(tip, self.geometry.link_lengths)]
        return out

    def leg_map(self) -> LegMap:
        """This robot as data: its leg map, the nominal stance and the servo gains included."""
        return hexapod.leg_map(self.geometry, stance=self.nominal_stance(), stance_height=self.stance_height)

    def robot(self) -> Robot:
        """The built model as MJCF text (no asset files) with its leg map: the form an uploaded
        robot takes (app/robots/legmap.py). The simulations still compile build() directly."""
        return Robot(name=self.name, mjcf=self.build().to_xml(), assets={}, legs=self.leg_map())

    def model(self, damage: Damage | DamageSpec = Damage(), pairs: bool = True, islands: bool = False,
              merged_fall: bool = True) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
        """The robot under ``damage`` (by its leg map's names, app/robots/damage.py; a
        ``DamageSpec`` by leg number is translated) on its floor. Two settings make its step faster and change no
        number (docs/recovery_speed.md, "Changes and their gains"): ``pairs``, its robot-floor
        contacts declared as explicit pairs instead of found by the broad phase each step
        (app/robots/contacts.py), and no constraint-island discovery (``islands`` False): the
        robot is one kinematic tree on a static floor, so all its constraints form one island
        and looking for more is wasted work. A third, ``merged_fall``, is the fall test's one
        contact sensor in place of one per watched body (``hexapod.add_fall_sensors``)."""
        spec = self.build()
        apply_damage(spec, hexapod.leg_map(self.geometry), damage.named() if isinstance(damage, DamageSpec) else damage)
        spec = hexapod.add_fall_sensors(spec, merged=merged_fall)
        if pairs:
            explicit_pairs(spec)
        if not islands:
            spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
        return spec, spec.compile()

    def describe(self) -> dict:
        g = self.geometry
        return {
            "name": self.name,
            "description": self.description,
            "legs": list(self.legs),
            "joints": list(self.joints),
            "leg_sides": {str(l.leg): ("left" if l.side < 0 else "right") for l in g.legs()},
            "hips_m": {str(l.leg): list(l.hip) for l in g.legs()},
            "link_lengths_m": list(g.link_lengths),
            "total_mass_kg": round(g.total_mass, 4),
            "parameters": {
                "x0_m": self.x0,
                "y0_m": {str(k): v for k, v in self.y0.items()},
                "stance_height_m": self.stance_height,
                "period_s": self.period_s,
                "pid": {"kp": g.kp, "kd": g.kd, "ki": g.ki},
            },
        }


JETHEXA = RobotEntry(
    name="jethexa",
    description="JetHexa-like 18-DoF hexapod (paper 000): 3-DoF legs, PID joint servos",
    geometry=hexapod.JETHEXA,
    build=lambda: hexapod.build_spec(hexapod.JETHEXA),
    legs=hexapod.LEG_IDS,
    joints=hexapod.JOINT_NAMES,
    x0=0.11,
    y0={1: 0.02, 2: 0.02, 3: 0.0, 4: 0.0, 5: -0.02, 6: -0.02},
    nominal_step_length=0.04,
    nominal_step_height=0.03,
    stance_height=0.10,
    period_s=0.6,
)

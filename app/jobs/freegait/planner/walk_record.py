"""What a walk records and returns (paper 004): its trace, one row per control period
(``WalkRecorder``), and the result with the numbers a user reads (``WalkResult``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.jobs.freegait.planner.walk_config import STOP_CAUSES
from app.jobs.freegait.planner.walk_sim import WalkSim
from app.jobs.freegait.planner.walk_state import GaitState, Period


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


class WalkRecorder:
    """The walk's trace, one row per control period."""

    KEYS = ("t", "pos", "rpy", "phase", "sm", "k_r", "v", "stop", "progress", "cmd_xy", "track_err", "k_ev", "crab_deg",
            "qpos", "tips")

    def __init__(self):
        self.cols: dict[str, list] = {k: [] for k in self.KEYS}

    def row(self, p: Period, g: GaitState, sim: WalkSim, cause: int | None = None) -> None:
        c, s = self.cols, p.s
        c["t"].append(p.t)
        c["pos"].append(np.array(s.pos))
        c["rpy"].append((s.roll, s.pitch, s.yaw))
        c["phase"].append(g.phase.copy())
        c["sm"].append(p.sm if np.isfinite(p.sm) else np.nan)
        c["k_r"].append(p.k_r)
        c["v"].append(p.v)
        c["stop"].append(p.cause if cause is None else cause)
        c["progress"].append(g.progress)
        c["cmd_xy"].append(g.cmd_xy.copy())
        c["track_err"].append(float(np.linalg.norm(np.asarray(s.pos[:2]) - g.cmd_xy)))
        c["k_ev"].append(p.params.k_ev)
        c["crab_deg"].append(math.degrees(g.alpha))
        c["qpos"].append(sim.state[1:1 + sim.model.nq].copy())
        c["tips"].append(s.tips_w.copy())

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.cols.items()}

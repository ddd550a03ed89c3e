"""Per-control-step cost of the tipping controller's math (issue target: FASM + judgment +
QP force distribution <= 1 ms on one core; the paper samples at 20 ms)."""

from __future__ import annotations

import time

import numpy as np

from app.robots.heavy_hexapod import HEAVY
from app.jobs.tipping.stability.fast import distribute_fast, plane_normal
from app.jobs.tipping.stability.fasm import TipDetector
from app.jobs.tipping.scenario import monitor

TARGET_MS = 1.0  # FASM + judgment + QP per control step, one core


def _state(rng: np.random.Generator, tilt_deg: float):
    """A four-leg stance (tripod 1-3-5 plus the caught leg 6) on a platform tilted about y,
    with contact forces that balance the weight, and small noise."""
    feet = np.stack([HEAVY.nominal_foot(l) for l in range(1, 7)]) + [0.0, 0.0, 1.74]
    c, s = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))
    R = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    feet = feet @ R.T + rng.normal(0, 0.005, feet.shape)
    com = R @ np.array([0.0, 0.0, 1.8])
    stance = [1, 3, 5, 6]
    forces = np.zeros((6, 3))
    forces[[l - 1 for l in stance], 2] = HEAVY.total_mass * 9.81 / 4
    forces += rng.normal(0, 50.0, forces.shape) * (forces[:, 2:3] > 0)
    return feet, forces, com, stance


def bench_tipping(steps: int = 500, seed: int = 0) -> dict:
    """Mean and 95th-percentile wall time of one control step's FASM (with SSM and NESM),
    tipping judgment and QP foot-force distribution, on one core."""
    rng = np.random.default_rng(seed)
    det = TipDetector()
    states = [_state(rng, 12.0 + 4.0 * rng.random()) for _ in range(32)]
    mass = HEAVY.total_mass
    g = (0.0, 0.0, -9.81)
    times = {"fasm": [], "judgment": [], "qp": [], "step": []}
    cpu0 = time.process_time()
    for k in range(steps):
        feet, forces, com, stance = states[k % len(states)]
        t0 = time.perf_counter()
        mon = monitor(feet, forces, com, stance)
        t1 = time.perf_counter()
        if det.update(0.02 * k, mon.margin_deg):
            det.time_to_tip()
        t2 = time.perf_counter()
        pts = [feet[l - 1].tolist() for l in stance]
        sol = distribute_fast(pts, com.tolist(), mass, g, normal=plane_normal(pts))
        t3 = time.perf_counter()
        times["fasm"].append(t1 - t0)
        times["judgment"].append(t2 - t1)
        times["qp"].append(t3 - t2)
        times["step"].append(t3 - t0)
    cpu = time.process_time() - cpu0
    out = {f"{k}_ms": 1e3 * float(np.mean(v[steps // 10:])) for k, v in times.items()}
    # CPU time is the fair "one core" figure on a shared machine; wall time is above.
    out["tipping_step_cpu_ms"] = 1e3 * cpu / steps
    out["tipping_step_ms"] = out.pop("step_ms")
    out["tipping_step_p95_ms"] = 1e3 * float(np.percentile(times["step"][steps // 10:], 95))
    out["qp_stability_constrained"] = bool(sol.stability_constrained)
    out["steps"] = steps
    # the target, on the wall time the bench reports (other work on the machine counts in it)
    out["targets"] = {"tipping_step_ms_max": TARGET_MS, "tipping_step_met": out["tipping_step_ms"] <= TARGET_MS}
    return out


if __name__ == "__main__":
    import json

    print(json.dumps(bench_tipping(), indent=2))

"""Figures of issue 23's closing note (not a test): upload-to-first-generation time, IK time
per population and simulated steps/s on uploaded robots against the built-in JetHexa, each
with the paper's population (30) and a 10 s walk, one generation (generation 0) plus one more.

    .venv/bin/python scripts/robot_recovery_figures.py [--json OUT]
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "robots"))
import legged_models as lm_  # noqa: E402

from app.jobs.base import MemoryContext  # noqa: E402
from app.jobs.recovery.run import run  # noqa: E402
from app.jobs.recovery.spec import RecoverySpec  # noqa: E402
from app.robots.detect import detect_legs  # noqa: E402
from app.robots.legmap import Robot  # noqa: E402
from app.robots.upload import Upload, from_dir, prepare  # noqa: E402

SEARCH = {"population": 30, "generations": 1, "seed": 0}
COMMON = {"search": SEARCH, "sim": {"duration_s": 10.0}, "controls": {"random_search": False},
          "robustness": {"cases": []}}


class Clock(MemoryContext):
    """Notes when generation 0 of the search is done (the first progress past one population)."""

    def __init__(self, t0: float, robots=None):
        super().__init__(robots=robots)
        self.t0, self.first = t0, None

    def progress(self, done, total, info):
        if self.first is None and done >= SEARCH["population"]:
            self.first = time.perf_counter() - self.t0


def _upload(name: str) -> tuple[Upload, str]:
    if name == "dm_control quadruped":
        path = lm_.dm_control_quadruped()
        folder = Path(tempfile.mkdtemp())
        shutil.copytree(path.parent / "common", folder / "common")
        return from_dir(path, folder), "knee_front_left"
    spec = lm_.build(lm_.HEXAPOD_OTHER)
    folder = Path(tempfile.mkdtemp())
    (folder / "hexapod_other.xml").write_text(spec.to_xml())
    return from_dir(folder / "hexapod_other.xml", None), ""


def uploaded(name: str) -> dict:
    t0 = time.perf_counter()
    upload, knee = _upload(name)
    p = prepare(upload)  # the upload's defence: pre-parse, confined compile, caps, detection
    robot = Robot(p.name, p.xml, p.assets, p.legs)
    t_upload = time.perf_counter() - t0
    legs = p.legs.legs
    damage = ({"locked_joints": [{"leg": "front_left", "joint": knee}]} if knee
              else {"lost_legs": [legs[0].name]})
    spec = RecoverySpec.parse({"kind": "recovery", "robot": "0" * 32, "robot_damage": damage, **COMMON})
    ctx = Clock(t0, robots=lambda rid: robot)
    s = run(spec, ctx).summary
    ik = s["uploaded_robot"]["ik"]
    return {"robot": name, "damage": damage, "upload_s": round(t_upload, 3),
            "upload_to_first_generation_s": round(ctx.first, 2),
            "ik_per_population_s": round(ik["population_wall_s"], 3), "ik_population_targets": ik["population_targets"],
            "ik_calls": ik["calls"], "ik_max_error_m": ik["max_error_m"], "ik_beyond_1mm": ik["beyond_1mm"],
            "ik_targets": ik["targets"],
            "sim_steps_per_s": round(s["timing"]["sim_steps_per_s"]), "best_forward_m": s["best"]["metrics"]["y_f_m"],
            "baseline_forward_m": s["baseline"]["metrics"]["y_f_m"]}


def builtin() -> dict:
    t0 = time.perf_counter()
    spec = RecoverySpec.parse({"kind": "recovery", "damage": {"lost_legs": [1, 6]}, **COMMON})
    ctx = Clock(t0)
    s = run(spec, ctx).summary
    return {"robot": "jethexa (built-in)", "damage": {"lost_legs": [1, 6]},
            "spec_to_first_generation_s": round(ctx.first, 2), "sim_steps_per_s": round(s["timing"]["sim_steps_per_s"])}


if __name__ == "__main__":
    load = os.getloadavg()[0]
    rows = [builtin(), uploaded("hexapod_other (MjSpec)"), uploaded("dm_control quadruped")]
    out = {"load_before": round(load, 2), "load_after": round(os.getloadavg()[0], 2), "cpus": os.cpu_count(),
           "search": SEARCH, "walk_s": 10.0, "rows": rows}
    text = json.dumps(out, indent=1)
    if "--json" in sys.argv:
        Path(sys.argv[sys.argv.index("--json") + 1]).write_text(text + "\n")
    print(text)

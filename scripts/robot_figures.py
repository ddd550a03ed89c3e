"""Figures for docs/robots.md's "Measured" table: upload-to-stored time of two third-party
robots, `gaitmend robot add` end to end, the batched IK per population of 30 x one gait
period, and raw mj_step rates of a built-in and two third-party robots. Each run is appended
to the JSON file --json-out names, with the machine, the 1-minute load before and after, the
niceness, the commit and the date (app/cli/bench.py ``measured``); the page shows the latest
(app/results/robot_figures.py). Needs the test extra (gymnasium, dm-control). From the
checkout:

    .venv/bin/python scripts/robot_figures.py --json-out docs/robot_figures.json
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "robots"))

import legged_models as lm_  # noqa: E402

from app.cli.bench import append_measured, measured  # noqa: E402
from app.robots.catalog import JETHEXA  # noqa: E402
from app.robots.numik import LegIK  # noqa: E402
from app.results.robot_figures import COMMAND  # noqa: E402
from app.robots.upload import from_dir, prepare  # noqa: E402

REPEATS = 3


def times(f, n: int = REPEATS) -> list[float]:
    out = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return out


def cli_add(ant: Path) -> list[float]:
    """`gaitmend robot add ant.xml --json` in a fresh data folder each time: CLI start,
    imports, the confined compile, the database."""
    out = []
    for _ in range(REPEATS):
        with tempfile.TemporaryDirectory() as data:
            env = {k: v for k, v in os.environ.items() if not k.startswith("GAITMEND_")} | {
                "GAITMEND_DATA_DIR": data, "PYTHONPATH": str(ROOT)}
            t = time.perf_counter()
            r = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "robot", "add", str(ant),
                                "--json"], env=env, cwd=data, capture_output=True, text=True, timeout=300)
            out.append(time.perf_counter() - t)
            if r.returncode != 0:
                raise SystemExit(f"gaitmend robot add failed: {r.stderr[-2000:]}")
    return out


def ik_figures(rng: np.random.Generator, ant: Path) -> dict:
    model, legs = JETHEXA.build().compile(), JETHEXA.leg_map()
    ik = LegIK(model, legs)
    out = {}
    for T in (600, 150):
        tg = ik.fk(ik.q_ref + rng.uniform(-0.25, 0.25, (30, T, ik.nq)))
        res = {}
        out[f"ik_jethexa_30x{T}_s"] = times(lambda: res.__setitem__("r", ik.solve(tg)))
        out[f"ik_jethexa_30x{T}_iterations"] = int(res["r"].iterations)
    m2 = mujoco.MjModel.from_xml_path(str(ant))
    ik2 = LegIK(m2, prepare(from_dir(ant, None)).legs)
    mid = np.where(np.isfinite(ik2.hi), (ik2.hi + ik2.lo) / 2, 0)
    tg = ik2.fk(mid + rng.uniform(-0.2, 0.2, (30, 600, ik2.nq)))
    out["ik_ant_30x600_s"] = times(lambda: ik2.solve(tg, q0=mid))
    return out


def step_rate(m: mujoco.MjModel, n: int = 20000) -> float:
    """mj_step from Python, one step per call (the per-call rate a user's loop sees)."""
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    t = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(m, d)
    return n / (time.perf_counter() - t)


def figures() -> dict:
    ant, quad = lm_.gymnasium_ant(), lm_.dm_control_quadruped()
    d = Path(tempfile.mkdtemp())
    try:
        shutil.copytree(quad.parent / "common", d / "common")
        out = {"prepare_ant_s": times(lambda: prepare(from_dir(ant, None))),
               "prepare_dm_quadruped_s": times(lambda: prepare(from_dir(quad, d))),
               "cli_add_ant_s": cli_add(ant)}
        out |= ik_figures(np.random.default_rng(0), ant)
        mq = mujoco.MjModel.from_xml_string(prepare(from_dir(quad, d)).xml)
        out["mj_step_per_s"] = {"jethexa": step_rate(JETHEXA.build().compile()),
                                "gymnasium ant": step_rate(mujoco.MjModel.from_xml_path(str(ant))),
                                "dm_control quadruped": step_rate(mq)}
    finally:
        shutil.rmtree(d, ignore_errors=True)
    return {"repeats": REPEATS, "figures": out}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json-out", type=Path, required=True, help="the file each run is appended to")
    args = ap.parse_args()
    append_measured(args.json_out, "robot-figures", COMMAND, ["robot figures"], lambda _: measured(figures),
                    lambda s: s, lambda s: print(s, file=sys.stderr, flush=True))


if __name__ == "__main__":
    main()

"""Figures for docs/robots.md: upload-to-stored time, IK time per population of 30 x one
gait period, raw mj_step rates of a built-in and two third-party robots. Needs the test
extra (gymnasium, dm-control). Run from the checkout: .venv/bin/python scripts/robot_figures.py"""
import json, shutil, tempfile, time, sys
from pathlib import Path
import mujoco, numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "robots"))
import legged_models as lm_
from app.robots.catalog import JETHEXA
from app.robots.numik import LegIK
from app.robots.upload import from_dir, prepare

def best(f, n=3):
    ts = []
    for _ in range(n):
        t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
    return min(ts), float(np.median(ts))

ant = lm_.gymnasium_ant(); q = lm_.dm_control_quadruped()
d = Path(tempfile.mkdtemp()); shutil.copytree(q.parent / "common", d / "common")
print("prepare ant (min, median s)", best(lambda: prepare(from_dir(ant, None))))
print("prepare dm_control quadruped", best(lambda: prepare(from_dir(q, d))))
model, legs = JETHEXA.build().compile(), JETHEXA.leg_map()
ik = LegIK(model, legs)
rng = np.random.default_rng(0)
for T in (600, 150):
    qs = ik.q_ref + rng.uniform(-0.25, 0.25, (30, T, ik.nq))
    tg = ik.fk(qs)
    res = {}
    def run(): res["r"] = ik.solve(tg)
    print(f"IK jethexa 30 x {T} x 6 legs (min, median s)", best(run), "iters", res["r"].iterations, "max err", float(res["r"].err.max()))
m2 = mujoco.MjModel.from_xml_path(str(ant)); l2 = prepare(from_dir(ant, None)).legs
ik2 = LegIK(m2, l2)
mid = np.where(np.isfinite(ik2.hi), (ik2.hi + ik2.lo) / 2, 0)
qs = mid + rng.uniform(-0.2, 0.2, (30, 600, ik2.nq)); tg = ik2.fk(qs)
print("IK ant 30 x 600 x 4 legs", best(lambda: ik2.solve(tg, q0=mid)))
def steps(m, n=20000):
    d = mujoco.MjData(m); mujoco.mj_forward(m, d)
    t = time.perf_counter()
    for _ in range(n): mujoco.mj_step(m, d)
    return n / (time.perf_counter() - t)
mq = mujoco.MjModel.from_xml_string(prepare(from_dir(q, d)).xml)
print("steps/s jethexa", steps(model), "ant", steps(m2), "dm quadruped", steps(mq))

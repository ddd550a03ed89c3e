"""The bundle's controller (issue 24): the module the simulation ran, run alone with only
numpy importable, gives the simulated set-points over a whole walk from the same readings."""

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from app.jobs.base import MemoryContext
from app.jobs.recovery.run import run
from app.jobs.registry import parse_spec
from app.results.bundle import write_bundle

SPEC = {"kind": "recovery", "damage": {"lost_legs": [1, 6]}, "search": {"population": 4, "generations": 1, "seed": 1},
        "controls": {"random_search": False}, "robustness": {"cases": ["friction_0.7"], "held_out": 0}}


CONTROLS = {"open_loop": {"mode": "open_loop"}, "closed_loop": {"mode": "closed_loop", "update": "phase"},
            "balance": {"mode": "closed_loop", "update": "phase", "balance_gain": 1.0, "balance_integral_gain": 0.3}}


@pytest.fixture(scope="module", params=list(CONTROLS))
def bundle(request, tmp_path_factory):
    spec = parse_spec(SPEC | {"control": CONTROLS[request.param]})
    res = run(spec, MemoryContext())
    tmp = tmp_path_factory.mktemp(request.param)
    path = write_bundle(tmp / "b.zip", "job", spec, res)
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp / "unzipped")
    return spec, res, tmp / "unzipped"


def numpy_only(tmp: Path) -> Path:
    """A folder holding numpy (and the libraries its wheel ships beside it) and nothing else."""
    site = Path(np.__file__).resolve().parent.parent
    out = tmp / "numpy_only"
    out.mkdir(exist_ok=True)
    for name in ("numpy", "numpy.libs"):
        if (site / name).exists() and not (out / name).exists():
            (out / name).symlink_to(site / name)
    return out


def check_alone(ctl: Path, tmp: Path) -> dict:
    """Runs a bundle's check_controller.py isolated (-I: no user site, no PYTHONPATH) without
    site-packages (-S): the standard library, numpy and the controller folder only; its report."""
    code = ("import sys; sys.path.insert(0, %r)\n"
            "for name in ('app', 'gaitmend', 'mujoco', 'scipy'):\n"
            "    try:\n        __import__(name)\n    except ImportError:\n        pass\n"
            "    else:\n        raise SystemExit(name + ' is importable: not a clean environment')\n"
            "import runpy; runpy.run_path('check_controller.py', run_name='__main__')\n") % str(numpy_only(tmp))
    out = subprocess.run([sys.executable, "-I", "-S", "-c", code], cwd=ctl, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_the_controller_alone_gives_the_simulated_setpoints_over_the_whole_walk(bundle, tmp_path):
    spec, res, folder = bundle
    ctl = folder / "controller"
    report = check_alone(ctl, tmp_path)
    g = json.loads((ctl / "gait.json").read_text())
    assert report["ticks"] == g["settle_steps"] + g["walk_steps"]  # the whole walk (it did not fall)
    assert report["max_abs_diff_rad"] <= 1e-9
    # the walk the check replays is the job's own trace
    walk = np.loadtxt(ctl / "simulated_walk.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(walk[:, 2:2 + len(g["joints"])], res.traces["best"]["ctrl"])
    assert (g["law"] is None) == (spec.control.mode == "open_loop")
    if spec.control.balance_gain > 0:  # the balance was at work in the walk replayed: tip heights moved
        from app.jobs.recovery.gait_controller import GaitController, walk as replay

        assert g["law"]["balance_gain"] == 1.0 and len(g["balance_levers_m"]) == 4
        c = GaitController.from_dict(g)
        state = walk[:, 2 + len(g["joints"]):]
        replay(c, lambda j: (state[None, g["settle_steps"] + j - 1, 3:7], state[None, g["settle_steps"] + j - 1, 0:3]),
               g["walk_steps"])
        assert c.cmd.shape == (1, 2 + 4) and np.abs(c.cmd[0, 2:]).max() > 1e-4


def test_the_module_shipped_is_the_module_that_ran(bundle):
    _, _, folder = bundle
    from app.jobs.recovery import gait_controller

    assert (folder / "controller" / "gait_controller.py").read_text() == Path(gait_controller.__file__).read_text()
    # ... and its IK is the robot layer's file, shipped beside it (the check script above runs
    # the pair outside gaitmend)
    from app.robots import ik

    assert (folder / "controller" / "ik.py").read_text() == Path(ik.__file__).read_text()
    from app.robots import chain_ik

    assert (folder / "controller" / "chain_ik.py").read_text() == Path(chain_ik.__file__).read_text()


def test_open_loop_setpoints_are_the_period_the_simulation_repeated(bundle):
    spec, res, folder = bundle
    ctl = folder / "controller"
    sp = json.loads((ctl / "setpoints.json").read_text())
    g = json.loads((ctl / "gait.json").read_text())
    assert sp["joints"] == [j["name"] for j in g["joints"]] and len(sp["joints"]) == 12
    assert sp["servo_rate_hz"] == pytest.approx(1.0 / spec.sim.timestep_s)
    assert sp["zero_offsets_rad"] == [0.0] * 12
    assert all(j["kp_nm_per_rad"] == 500.0 and j["torque_limit_nm"] == 3.4 for j in g["joints"])
    csv = np.loadtxt(ctl / "setpoints.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(csv[1:, 2:], np.array(sp["period_rad"]))
    np.testing.assert_array_equal(csv[0, 2:], np.array(sp["settle_pose_rad"]))
    ctrl = res.traces["best"]["ctrl"]
    n0, n = sp["settle_steps"], sp["period_steps"]
    np.testing.assert_array_equal(ctrl[:n0], np.tile(sp["settle_pose_rad"], (n0, 1)))
    if spec.control.mode == "open_loop":
        k = np.arange(ctrl.shape[0] - n0)
        np.testing.assert_array_equal(ctrl[n0:], np.array(sp["period_rad"])[k % n])


def test_the_bundle_readme_describes_the_controller(bundle):
    _, _, folder = bundle
    readme = (folder / "README.md").read_text()
    assert "`controller/gait_controller.py` | the gait's set-points and its closed-loop correction" in readme
    text = (folder / "controller" / "README.md").read_text()
    assert "Not modelled" in text and "latency" in text and "backlash" in text and "noise" in text

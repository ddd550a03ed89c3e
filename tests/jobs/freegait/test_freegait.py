"""The ``freegait`` kind: bad specs exit 2 naming the field (CLI, as a user runs it), a short
job with its controls and robustness, determinism, presentation."""

import json
import subprocess
import sys

import numpy as np
import pytest

from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.freegait import KIND
from app.jobs.freegait.spec import max_speed

SHORT = {"kind": "freegait", "route": {"distance_m": 0.3}, "terrain": {"length_m": 3.0, "width_m": 3.0},
         "forbidden": {"density_per_m2": 6.0}}


def gaitmend(*args):
    return subprocess.run([sys.executable, "-m", "app", *args], capture_output=True, text=True, timeout=600)


BAD = [
    ({"route": {"crab_angle_deg": 60.0}}, "route.crab_angle_deg: Input should be less than or equal to 45"),
    ({"route": {"changes": [{"at_s": 5.0, "crab_angle_deg": -50.0}]}}, "route.changes.0.crab_angle_deg"),
    ({"planner": {"sm_min_m": -0.01}}, "planner.sm_min_m: Input should be greater than or equal to 0"),
    ({"planner": {"candidates_per_leg": 1}}, "planner.candidates_per_leg: 1: at least 2 candidates per leg"),
    ({"planner": {"candidates_per_leg": 50}}, "planner.candidates_per_leg: 50: N^3 = 125000 tripods exceeds the cap of 64000"),
    ({"route": {"distance_m": 2.5}}, "route: the robot would leave the terrain"),
    ({"route": {"speed_m_s": 0.05}}, "route.speed_m_s: 0.05 outside"),
    ({"terrain": {"roughness_m": 0.08}, "planner": {"h3_m": 0.12}}, "terrain.roughness_m: 0.08 must stay below H3/2"),
    ({"route": {"gait": "spinning"}}, "route.speed_m_s: a spinning gait turns in place"),
    ({"route": {"speed_m_s": "0.02"}}, "route.speed_m_s: Input should be a valid number"),
    ({"forbidden": {"safe_diameter_m": 0.02}}, "forbidden: safe_diameter_m 0.02 is smaller than zone_diameter_m"),
    ({"mines": 3}, "mines: unknown field"),
]


def _patched(patch):
    spec = dict(SHORT)
    for k, v in patch.items():
        spec[k] = {**spec.get(k, {}), **v} if isinstance(v, dict) else v
    return spec


@pytest.mark.parametrize("patch,needle", BAD)
def test_bad_specs_name_the_field(patch, needle):
    with pytest.raises(SpecError) as e:
        KIND.Spec.parse(_patched(patch))
    assert needle in " ".join(str(e.value).split())


@pytest.mark.parametrize("k", [0, 4, 5])  # crab angle, N^3 over the cap, route leaving the terrain
def test_bad_specs_exit_2_on_the_cli_and_write_nothing(tmp_path, k):
    patch, needle = BAD[k]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(_patched(patch)))
    p = gaitmend("run", str(path), "--out", str(tmp_path / "out"))
    assert p.returncode == 2, p.stderr
    assert needle in " ".join(p.stderr.split())
    assert not (tmp_path / "out").exists()


def test_speed_bound_is_the_support_condition_limit():
    # Table 1's 0.05 m/s cannot satisfy conditions 3 and 4 with Sec. 5's transfer parameters.
    assert 0.025 < max_speed(KIND.default_spec().params()) < 0.035
    with pytest.raises(SpecError):
        KIND.Spec.parse({"kind": "freegait", "route": {"speed_m_s": 0.0}})


@pytest.fixture(scope="module")
def short_result():
    return KIND.run(KIND.Spec.parse(SHORT), MemoryContext())


def test_short_job_has_controls_robustness_and_no_zone_footholds(short_result):
    s = short_result.summary
    assert s["finished"] and s["footholds_in_zones"] == 0 and s["footholds"] >= 6
    assert [c["name"] for c in s["controls"]] == ["unaware", "periodic", "random_valid"]
    for c in s["controls"]:
        assert c["evaluations"] == 1 and set(c["metrics"]) >= {"footholds_in_zones", "finished", "min_sm_m"}
    rb = s["robustness"]
    assert rb["total"] == 7 and len(rb["cases"]) == 7
    assert all(c["metrics"]["footholds_in_zones"] == 0 for c in rb["cases"])
    assert short_result.evaluations == KIND.Spec.parse(SHORT).evaluations_budget == 11
    json.loads(dumps(s))  # JSON-clean
    assert {"walk", "unaware"} <= set(short_result.traces) and "qpos" in short_result.traces["walk"]
    assert short_result.history and {"tripod", "ev", "sm_t", "transfer_s"} <= set(short_result.history[-1])


def test_presentation(short_result, tmp_path):
    s = short_result.summary
    rows = KIND.headline(s)
    assert rows[0]["label"] == "footholds in forbidden zones" and rows[0]["met"] is True
    assert KIND.summary_tables(s)[0]["rows"][0][0] == "walk"
    views = KIND.views(s, short_result.traces)
    assert views[0]["id"] == "minefield" and views[0]["figure"]["layout"]["shapes"]
    json.loads(dumps(views))
    files = {p.name for p in KIND.figures(short_result, tmp_path)}
    assert {"minefield.svg", "margins.svg", "gait_diagram.svg"} <= files


def test_deterministic_resumable_and_cancellable(short_result):
    from app.jobs.base import Cancelled

    spec = KIND.Spec.parse(SHORT | {"evidence": {"controls": True, "robustness": False}})
    ctx = MemoryContext()
    first = KIND.run(spec, ctx)
    # the same spec and seed: the same numbers (the walk and controls of the fixture's job)
    for k in ("footholds_list", "min_sm_m", "min_k_r_m", "tracking_error_max_m", "footholds_in_zones"):
        assert first.summary[k] == short_result.summary[k]
    assert first.summary["controls"] == short_result.summary["controls"]
    np.testing.assert_array_equal(first.traces["walk"]["qpos"], short_result.traces["walk"]["qpos"])
    state = ctx.load_checkpoint()
    assert {g: set(entry["units"]) for g, entry in state.items()} == {"walk": {"walk"},
                                                                     "control": {"unaware", "periodic", "random_valid"}}
    # a worker that died after the last unit: the resumed job re-simulates only what it must draw
    resumed = KIND.run(spec, ctx)
    assert resumed.summary["controls"] == first.summary["controls"]
    assert resumed.summary["footholds_list"] == first.summary["footholds_list"]

    class Cancelling(MemoryContext):
        def is_cancelled(self):
            return True

    with pytest.raises(Cancelled):
        KIND.run(spec, Cancelling())

"""Held-out planner draws and perturbed physics for a best gait set (paper 001 evidence)."""

import numpy as np
import pytest

from app.jobs.multigait.planner.costs import evaluate
from app.jobs.evidence import CASES as STANDARD, Robustness
from app.jobs.multigait.evidence import (CASES, CHUNK, gait_metrics, heldout_values, physics, robustness_cases,
                                         robustness_target)
from app.jobs.multigait.planner.maps import get_map
from app.jobs.multigait.planner.primitives import ModularSim
from app.robots.modular import get_shape

SHAPE = get_shape("lizard")
PMAP = get_map("empty")


@pytest.fixture(scope="module")
def sim():
    s = ModularSim(SHAPE, (), PMAP, gait_s=4.0, settle_s=0.5)
    yield s
    s.close()


@pytest.fixture(scope="module")
def gaits(sim):
    lo, hi = sim.bounds(3)
    return lo + np.random.default_rng(2).random(lo.size) * (hi - lo)


def test_heldout_plans_use_fresh_draws_and_chunking_changes_nothing(sim, gaits):
    ticks = []
    ev = evaluate(sim, gaits[None], 3, PMAP, 40, "coverage", 0, SHAPE.radius_mu())
    many = heldout_values(sim, gaits, 3, PMAP, 40, "coverage", 0, SHAPE.radius_mu(), CHUNK + 3, prims=ev.prims,
                          tick=ticks.append)
    assert sum(ticks) == CHUNK + 3 and len(ticks) == 2  # progress and cancel between chunks
    few = heldout_values(sim, gaits, 3, PMAP, 40, "coverage", 0, SHAPE.radius_mu(), 3)  # simulates again
    assert np.array_equal(many[:3], few)
    # other draws, other trees: the in-sample value is one draw among many, not the held-out mean
    assert len(np.unique(many)) > 1
    assert np.all((many > 0) & (many <= 100))


def test_robustness_cases_are_real_resimulations(gaits):
    seen = []
    cases = robustness_cases(SHAPE, (), PMAP, 4.0, 0.5, gaits, 3, 40, "coverage", 0, SHAPE.radius_mu(),
                             cases=CASES[:3], tick=seen.append)
    assert [c["name"] for c in cases] == ["dt_half", "dt_quarter", "friction_0.7"] and sum(seen) == 3
    sim = ModularSim(SHAPE, (), PMAP, 4.0, 0.5, physics=physics(CASES[1]))
    try:
        assert sim.dt == pytest.approx(0.0025) and sim.nstep == 4 * 450
        again = gait_metrics(sim, gaits, 3, PMAP, 40, "coverage", 0, SHAPE.radius_mu())
    finally:
        sim.close()
    assert again == cases[1]["metrics"]  # deterministic
    nominal_sim = ModularSim(SHAPE, (), PMAP, 4.0, 0.5)
    try:
        nominal = gait_metrics(nominal_sim, gaits, 3, PMAP, 40, "coverage", 0, SHAPE.radius_mu())
    finally:
        nominal_sim.close()
    # the perturbed physics moves the gaits differently (not a copy of the nominal numbers)
    assert all(c["metrics"]["gait_distance_mu"] != nominal["gait_distance_mu"] for c in cases)
    target = robustness_target("coverage", nominal["coverage_pct"])
    for c in cases:
        c["target_met"] = target.met(c["metrics"])
    block = Robustness.build(target.text, nominal, cases).to_json()
    assert block["total"] == 3 and block["met"] == sum(c["target_met"] for c in cases)
    sp = block["spread"]["coverage_pct"]
    assert sp["min"] <= sp["nominal"] <= sp["max"]


def test_the_cases_are_the_standard_ones_with_this_kinds_labels():
    for c in CASES:
        std = STANDARD[c.name]
        assert (c.group, c.timestep_scale, c.friction_scale, c.mass_scale) == \
            (std.group, std.timestep_scale, std.friction_scale, std.mass_scale)
    assert CASES[0].label == "timestep halved (5 ms)" and CASES[0].group == "numerics"
    p = physics(CASES[2])
    assert p.friction == pytest.approx(0.7 * physics(CASES[0]).friction) and p.timestep == physics(CASES[3]).timestep


def test_one_target_judges_coverage_relative_to_the_nominal_and_distance_absolutely():
    t = robustness_target("coverage", 50.0)
    assert t.text == "coverage at least 80% of the nominal 50.0 %"
    assert t.met({"coverage_pct": 40.0}) and not t.met({"coverage_pct": 39.9})
    d = robustness_target("distance", 50.0)
    assert d.met({"goal_distance_mu": 2.0}) and not d.met({"goal_distance_mu": 2.01})

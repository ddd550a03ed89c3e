"""Held-out planner draws and perturbed physics for a best gait set (paper 001 evidence)."""

import numpy as np
import pytest

from app.jobs.multigait.planner.costs import evaluate
from app.jobs.multigait.evidence import CASES, CHUNK, gait_metrics, heldout_values, robustness_cases
from app.sim.perturb import robustness_block
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
    sim = ModularSim(SHAPE, (), PMAP, 4.0, 0.5, physics=CASES[1].physics())
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
    for c in cases:
        c["target_met"] = c["metrics"]["coverage_pct"] >= 0.8 * nominal["coverage_pct"]
    block = robustness_block("coverage >= 80 % of nominal", nominal, cases)
    assert block["total"] == 3 and block["met"] == sum(c["target_met"] for c in cases)
    sp = block["spread"]["coverage_pct"]
    assert sp["min"] <= sp["nominal"] <= sp["max"]

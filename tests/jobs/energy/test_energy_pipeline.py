"""One fitness evaluation end to end on the paper's trot (Table 1), and its failure modes."""

import dataclasses

import numpy as np
import pytest

from app.jobs.energy.dynamics.gait import Task, trot
from app.jobs.energy.dynamics.physics import PhysicsConfig, reference_from, simulate
from app.jobs.energy.dynamics.pipeline import PENALTY, EvalConfig, evaluate
from app.robots.quadruped import QUADRUPED25


@pytest.fixture(scope="module")
def table1():
    return evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig(), detail=True)


def test_table1_trot_is_periodic_and_the_qp_removes_the_residual(table1):
    r = table1
    assert r["feasible"] and r["failed"] is None
    assert r["periodicity_error"] < 1.0
    # eps_QP at least 100x below the paper's eps_NLP (SRB + dummy legs, first pass).
    assert r["eps"]["qp"]["norm"] * 100 < r["eps"]["nlp"]["norm"]
    assert r["eps"]["nlp_iterated"]["norm"] < r["eps"]["nlp"]["norm"]
    assert r["qp_failures"] == 0
    for stage in ("nlp", "qp", "final"):
        assert 0.05 < r["cot"][stage] < 5.0
    assert r["fitness"] == pytest.approx(r["objective_terms"]["cot"] + r["objective_terms"]["jerk"])
    # Without the QP forces the multibody equations drift (Fig. 4's blue curve).
    assert r["nlp_forward_periodicity_error"] > r["periodicity_error"]
    f = r["trajectories"]["f_qp"]
    assert (f[..., 2] >= -1e-9).all()
    assert (np.linalg.norm(f[..., :2], axis=-1) <= 0.6 * f[..., 2] + 1e-6).all()


def test_massless_legs_leave_a_larger_residual():
    srb = evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig(leg_dynamics=False))
    legs = evaluate(QUADRUPED25, trot(0.46), Task(), EvalConfig())
    assert srb["eps"]["nlp"]["norm"] > 5 * legs["eps"]["nlp"]["norm"]


def test_unreachable_links_get_the_reach_penalty():
    g = dataclasses.replace(QUADRUPED25, links=(0.06, 0.2, 0.2))
    r = evaluate(g, trot(0.46), Task())
    assert not r["feasible"] and r["failed"] == "ik_reach"
    assert r["fitness"] >= PENALTY["ik_reach"]


def test_evaluation_is_deterministic():
    a = evaluate(QUADRUPED25, trot(0.5), Task())
    b = evaluate(QUADRUPED25, trot(0.5), Task())
    assert a["fitness"] == b["fitness"] and a["eps"] == b["eps"]


def test_the_trot_walks_in_full_physics(table1):
    ref = reference_from(table1["trajectories"], trot(0.46), 1.0)
    p = simulate(QUADRUPED25, ref, 0.6, PhysicsConfig(periods=3))
    assert p["stays_up"] and p["periods_completed"] == 3
    assert p["speed_m_s"] == pytest.approx(1.0, rel=0.1)
    assert p["mean_height_m"] == pytest.approx(0.5, abs=0.03)
    # Dropping the feed-forward torques and the gains: it falls (the check can fail).
    weak = simulate(QUADRUPED25, dataclasses.replace(ref, tau=ref.tau * 0.0), 0.6,
                    PhysicsConfig(periods=3, kp_joint=5.0, kd_joint=0.1))
    assert not weak["stays_up"]


def test_a_free_walk_with_four_phases_is_feasible():
    from app.jobs.energy.dynamics.gait import Gait

    T = 0.6
    walk = Gait(period=T, touchdown=(0.0, 0.5 * T, 0.75 * T, 0.25 * T), duty=(0.75,) * 4)
    r = evaluate(QUADRUPED25, walk, Task(), EvalConfig(knots=96))
    assert r["feasible"], r["failed"]
    assert r["eps"]["qp"]["norm"] * 100 < r["eps"]["nlp"]["norm"]


def test_foot_placement_holds_a_slow_trot_that_open_loop_tracking_drops():
    # The GA's answer at T = 0.8 s (seed 0, 16 x 9): long stances on a line of two feet.
    g = dataclasses.replace(QUADRUPED25, links=(0.0424, 0.3120, 0.2990))
    r = evaluate(g, trot(0.8), Task(), EvalConfig(), detail=True)
    assert r["feasible"]
    ref = reference_from(r["trajectories"], trot(0.8), 1.0)
    open_loop = simulate(g, ref, 0.6, PhysicsConfig(periods=5, balance=False))
    placed = simulate(g, ref, 0.6, PhysicsConfig(periods=5, balance=False, foot_placement_s=0.5 * 0.4))
    assert not open_loop["stays_up"]
    assert placed["stays_up"] and placed["speed_m_s"] == pytest.approx(1.0, rel=0.1)

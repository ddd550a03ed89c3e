"""The contact-force NLP (paper 003, Eq. 8) on hand-checkable cases and its constraints."""

import math

import numpy as np
import pytest

from app.jobs.energy.dynamics.dummy_legs import dummy_leg_wrench, nominal_body
from app.jobs.energy.dynamics.gait import Gait, Task, feet_world, trot
from app.jobs.energy.dynamics.nlp import SRBNLP, SRBProblem
from app.jobs.energy.dynamics.whole_body import GRAVITY, WholeBody
from app.robots.quadruped import QUADRUPED25

STAND = Gait(period=0.5, touchdown=(0.0, 0.0, 0.0, 0.0), duty=(1.0, 1.0, 1.0, 1.0))


def _standing_problem(feet_xy, mass=26.52, legs=None, k=3):
    K = 40
    feet = np.zeros((K + 1, 4, 3))
    feet[:, :, :2] = feet_xy
    fl = np.zeros((K + 1, 3)) if legs is None else legs[0]
    ml = np.zeros((K + 1, 3)) if legs is None else legs[1]
    return SRBProblem(gait=STAND, mass=mass, inertia=np.array([0.35, 2.1, 2.1]), speed=0.0, height=0.5,
                      friction=0.6, feet=feet, f_legs=fl, m_legs=ml, k=k, weight=mass * GRAVITY)


def test_standing_robot_with_its_real_legs_splits_its_weight_by_the_lever_rule():
    import mujoco

    g = QUADRUPED25
    wb = WholeBody(g)
    legs, fl, ml = dummy_leg_wrench(wb, STAND, Task(speed=0.0), 40)
    # The whole robot's CoM in this pose (the knees bend forward, so it is not at the trunk's).
    wb.data.qpos[:] = wb.qpos(np.array([[0.0, 0.0, 0.5]]), np.zeros((1, 3)), legs.q[:1])[0]
    mujoco.mj_kinematics(wb.model, wb.data)
    mujoco.mj_comPos(wb.model, wb.data)
    x_com = wb.data.subtree_com[wb.model.body("trunk").id][0]
    close = lambda a: np.vstack([a, a[:1]])
    feet = feet_world(STAND, Task(speed=0.0), g, np.arange(41) * 0.5 / 40)
    prob = _standing_problem(feet[0, :, :2], mass=g.trunk_mass, legs=(close(fl), close(ml)))
    prob.weight = g.total_mass * GRAVITY
    sol = SRBNLP(prob).solve(nominal_body(Task(speed=0.0), np.arange(41) * 0.5 / 40)[0])
    assert sol.success
    # The legs' own weight reaches the trunk through the dummy legs: the feet carry all of it,
    # the front pair (x = +0.3) the share the lever rule about the robot's CoM gives.
    W = g.total_mass * GRAVITY
    front = W * (x_com + 0.3) / 0.6 / 2
    assert abs(x_com) > 1e-3
    assert sol.forces[:, [0, 2], 2] == pytest.approx(front, rel=1e-6)
    assert sol.forces[:, [1, 3], 2] == pytest.approx(W / 2 - front, rel=1e-6)
    assert np.abs(sol.forces[:, :, :2]).max() < 1e-6
    assert sol.jerk == pytest.approx(0.0, abs=1e-6)
    assert np.abs(sol.v).max() < 1e-9 and sol.r[:, 2] == pytest.approx(0.5)


def test_standing_weight_splits_by_the_lever_rule():
    # Front feet 0.3 m ahead of the CoM, hind feet 0.5 m behind: the front pair carries 5/8.
    xy = np.array([[0.3, -0.2], [-0.5, -0.2], [0.3, 0.2], [-0.5, 0.2]])
    prob = _standing_problem(xy)
    sol = SRBNLP(prob).solve(np.tile([0.0, 0.0, 0.5], (41, 1)))
    assert sol.success
    W = prob.mass * GRAVITY
    assert sol.forces[:, [0, 2], 2] == pytest.approx(W * 0.5 / 0.8 / 2, rel=1e-6)
    assert sol.forces[:, [1, 3], 2] == pytest.approx(W * 0.3 / 0.8 / 2, rel=1e-6)
    assert sol.jerk == pytest.approx(0.0, abs=1e-6)


@pytest.fixture(scope="module")
def trot_solution():
    g, task, gait = QUADRUPED25, Task(), trot(0.46)
    wb = WholeBody(g)
    K = 96
    _, fl, ml = dummy_leg_wrench(wb, gait, task, K)
    tk = np.arange(K + 1) * gait.period / K
    close = lambda a: np.vstack([a, a[:1]])
    prob = SRBProblem(gait=gait, mass=g.trunk_mass, inertia=np.array(g.trunk_inertia), speed=1.0, height=0.5,
                      friction=0.6, feet=feet_world(gait, task, g, tk), f_legs=close(fl), m_legs=close(ml), k=4,
                      weight=g.total_mass * GRAVITY)
    nlp = SRBNLP(prob)
    return nlp, nlp.solve(nominal_body(task, tk)[0])


def test_trot_nlp_meets_every_constraint(trot_solution):
    nlp, sol = trot_solution
    assert sol.success and sol.constraint_violation < 1e-8
    F = sol.forces
    _, stance = nlp.p.gait.phase(sol.t)
    assert np.abs(F[~stance]).max() == 0.0  # no force in swing, nor at touchdown / lift-off
    assert (F[..., 2] >= -1e-9).all()
    tangential = np.linalg.norm(F[..., :2], axis=-1)
    assert (tangential <= 0.6 * F[..., 2] + 1e-9).all()  # Eq. 6, the circular cone
    for i in range(4):  # Fig. 2: F_x rises negative at touchdown and falls from positive at lift-off
        rows = np.flatnonzero(stance[:-1, i])
        assert F[rows[0], i, 0] < 0 and F[rows[-1], i, 0] > 0
        assert sol.force_rate[rows[0], i, 0] < 0 and sol.force_rate[rows[-1], i, 0] < 0
    T = nlp.T
    # Eq. 7 as intended: mean speed V over the period, periodic state, mean height h.
    assert (sol.r[-1, 0] - sol.r[0, 0]) / T == pytest.approx(1.0, abs=1e-9)
    assert sol.v[-1] == pytest.approx(sol.v[0], abs=1e-9)
    assert sol.r[-1, 1:] == pytest.approx(sol.r[0, 1:], abs=1e-9)
    assert sol.theta[-1] == pytest.approx(sol.theta[0], abs=1e-8)
    assert sol.omega[-1] == pytest.approx(sol.omega[0], abs=1e-8)
    assert nlp.wmean @ sol.r[:, 2] == pytest.approx(0.5, abs=1e-9)
    # The shooting is the SRB equation (Eq. 5): m a = m g + sum f + f_l on every knot.
    a_model = np.array([0, 0, -GRAVITY]) + (F.sum(1) + nlp.p.f_legs) / nlp.p.mass
    assert sol.a == pytest.approx(a_model, abs=1e-9)


def test_slsqp_on_the_bilinear_problem_agrees_with_the_linearised_sweeps(trot_solution):
    nlp, sol = trot_solution
    polished = nlp.solve(nominal_body(Task(), nlp.t)[0], polish=True)
    assert polished.constraint_violation < 1e-6
    assert polished.jerk <= sol.jerk * (1 + 1e-6)
    assert polished.jerk == pytest.approx(sol.jerk, rel=1e-3)

"""The recovery robot's fast step settings (RobotEntry.model) change no number: explicit
contact pairs (app/robots/contacts.py, the broad phase's contacts declared once) and no
constraint-island discovery simulate the same bit for bit as MuJoCo's broad phase with
islands, on the nominal floor and on every perturbed world a job builds (robustness cases,
random held-out models); a world where pairs would not be exact is left alone."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from mujoco import rollout

from app.jobs.recovery.cases import draw_models, random_models, walking_cases
from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
from app.jobs.recovery.run import functional_legs, search_bounds
from app.jobs.recovery.sequences import plan_hexapod
from app.jobs.recovery.spec import RecoverySpec
from app.robots.catalog import JETHEXA
from app.robots.contacts import candidate_pairs, explicit_pairs
from app.robots.damage import DamageSpec
from app.sim.perturb import perturbed_model


def _worlds(lost: tuple[int, ...], **settings) -> list[mujoco.MjModel]:
    """The nominal world, the seven robustness cases of the same structure (dt cases aside:
    they only change the step) and three random held-out models."""
    mspec, model = JETHEXA.model(DamageSpec(lost_legs=lost), **settings)
    mass = JETHEXA.geometry.total_mass
    cases = [c for c in walking_cases(mass) if c.timestep_scale == 1.0]
    return [model] + [perturbed_model(mspec, c, model) for c in cases] + random_models(mspec, draw_models(0, 3), mass)


def _walks(lost: tuple[int, ...], n: int = 6, steps: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Initial states and controls of ``n`` random gaits, the last one started with the
    chassis on the floor (so the chassis-floor pair is exercised on every robot)."""
    spec = RecoverySpec(damage={"lost_legs": list(lost)})
    _, model = JETHEXA.model(DamageSpec(lost_legs=lost))
    seq = plan_hexapod(lost, JETHEXA.nominal_feet_xy(), JETHEXA.stance_com_xy(model, spec.gait.stance_height_m))
    ev = GaitEvaluator(JETHEXA, model, seq, SimConfig(nthread=1))
    lower, upper = search_bounds(spec, JETHEXA)
    x = lower + np.random.default_rng(3).random((n, lower.size)) * (upper - lower)
    ctrl, state = ev.controls(x)
    ev.close()
    state[-1, 1 + 2] = 0.02  # FULLPHYSICS state: time, then qpos (the torso's height third)
    assert len(functional_legs(spec)) == 6 - len(lost)
    return state, ctrl[:, :steps]


@pytest.mark.parametrize("lost", [(1, 6), ()])
def test_fast_step_settings_simulate_as_before_bit_for_bit(lost):
    state, ctrl = _walks(lost)
    broad, paired = _worlds(lost, pairs=False, islands=True), _worlds(lost)
    assert paired[0].opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND
    assert not broad[0].opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND and broad[0].npair == 0
    assert paired[0].npair == len(candidate_pairs(broad[0])) > 0
    assert not paired[0].geom_contype.any() and not paired[0].geom_conaffinity.any()
    assert candidate_pairs(paired[0]) == []  # the broad phase has nothing left to find
    touched_upper = False
    for a, b in zip(broad, paired):
        sa, da = rollout.rollout(a, mujoco.MjData(a), state, ctrl)
        sb, db = rollout.rollout(b, mujoco.MjData(b), state, ctrl)
        assert np.array_equal(sa, sb) and np.array_equal(da, db)
        feet = [a.sensor_adr[i] for i in range(a.nsensor) if a.sensor(i).name.endswith("_foot_touch")]
        upper = da[..., a.sensor_adr[a.sensor("all_contacts").id]] - da[..., feet].sum(axis=-1)
        touched_upper |= bool((upper > 0).any())
    assert touched_upper  # some walk put a chassis, coxa or femur on the floor: those pairs were exercised


@pytest.mark.parametrize("lost", [(1, 6), (1,)])
def test_the_fall_sensor_counts_exactly_the_upper_bodies_ground_contacts(lost):
    """The fall test's contact count (every contact less the feet's, one sensor) against
    MuJoCo's contact list itself, step by step, on every world a job builds: it is
    positive exactly when the chassis, a coxa or a femur touches the ground, on walks that
    fall and walks that do not."""
    from app.robots.hexapod import FALL_BODIES

    state, ctrl = _walks(lost, n=3, steps=1000)
    hit = 0
    for m in _worlds(lost):
        ev = GaitEvaluator(JETHEXA, m, plan_hexapod(lost, JETHEXA.nominal_feet_xy(), JETHEXA.stance_com_xy(m, 0.1)),
                           SimConfig(nthread=1))
        watched = {m.body(b).id for b in FALL_BODIES if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) >= 0}
        d = mujoco.MjData(m)
        for x0, u in zip(state, ctrl):
            mujoco.mj_setState(m, d, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
            for k in range(u.shape[0]):
                d.ctrl[:] = u[k]
                mujoco.mj_step(m, d)
                truth = any(m.geom_bodyid[g] in watched for c in d.contact[: d.ncon] for g in (c.geom1, c.geom2))
                count = ev.ground_contacts(d.sensordata.copy())[0]
                assert (count > 0) == truth, (k, count, truth)
                hit += truth
        ev.close()
    assert hit > 0  # some walk put an upper body on the ground


def test_friction_edits_reach_the_pairs():
    """A friction case changes the paired world as it changes the broad-phase one."""
    state, ctrl = _walks((1, 6), n=3, steps=2000)
    mspec, model = JETHEXA.model(DamageSpec(lost_legs=(1, 6)))
    low = perturbed_model(mspec, next(c for c in walking_cases(1.0) if c.name == "friction_0.7"), model)
    assert np.allclose(low.pair_friction[:, :2], 0.7 * model.pair_friction[:, :2])
    assert np.array_equal(low.pair_friction[:, 2:], model.pair_friction[:, 2:])
    s0, _ = rollout.rollout(model, mujoco.MjData(model), state, ctrl)
    s1, _ = rollout.rollout(low, mujoco.MjData(low), state, ctrl)
    assert not np.array_equal(s0, s1)


def _ball_world(self_collide: bool = False) -> mujoco.MjSpec:
    """A floor and a capsule-and-ball body whose contact settings differ from the floor's in
    every way the mixing rule looks at."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1], friction=[0.8, 0.01, 1e-4],
                            solmix=2.0, solref=[0.03, 0.9], margin=0.001)
    spec.worldbody.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 1, 0.3], pos=[0.35, 0, 0.3],
                            priority=1, condim=1, friction=[0.3, 0.005, 1e-4], solref=[0.01, 1.2])
    body = spec.worldbody.add_body(name="ball", pos=[0, 0, 0.3])
    body.add_freejoint()
    body.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0], condim=4,
                  friction=[1.2, 0.002, 3e-4], solmix=0.5, solimp=[0.8, 0.9, 0.002, 0.5, 2], gap=0.0005)
    arm = body.add_body(name="arm", pos=[0.1, 0, 0])
    arm.add_joint(name="hinge", axis=[0, 1, 0])
    arm.add_geom(name="arm", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0.15, 0, 0], size=[0.02, 0, 0])
    if self_collide:
        other = spec.worldbody.add_body(name="other", pos=[0, 0.3, 0.3])
        other.add_freejoint()
        other.add_geom(name="other", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0])
    return spec


def test_mixed_parameters_are_mujocos():
    """Each pair carries what MuJoCo's mixing gives the dynamic contact: priority, largest
    condim and friction, solmix-weighted solref and solimp, largest margin and gap."""
    spec = _ball_world()
    broad = spec.copy().compile()
    assert explicit_pairs(spec)
    paired = spec.compile()
    assert paired.npair == 4  # ball and arm against floor and wall (ball-arm: parent and child, filtered)
    da, db = mujoco.MjData(broad), mujoco.MjData(paired)
    for d in (da, db):
        d.qvel[0] = 2.0  # rolls into the wall
    seen = set()
    for _ in range(600):
        mujoco.mj_step(broad, da)
        mujoco.mj_step(paired, db)
        assert np.array_equal(da.qpos, db.qpos) and np.array_equal(da.qvel, db.qvel)
        for i in range(da.ncon):
            ca = da.contact[i]
            cb = next(db.contact[j] for j in range(db.ncon) if set(db.contact[j].geom) == set(ca.geom))
            for f in ("dim", "friction", "solref", "solimp", "includemargin"):
                assert np.array_equal(getattr(ca, f), getattr(cb, f)), f
            seen.add(tuple(sorted(ca.geom)))
    assert len(seen) >= 2  # the floor and the wall were both touched


def test_worlds_where_pairs_would_not_be_exact_are_left_alone():
    spec = _ball_world(self_collide=True)  # two free bodies can meet: a pair without the world
    before = spec.to_xml()
    assert not explicit_pairs(spec)
    assert spec.to_xml() == before


def test_an_excluded_body_pair_is_no_pair_to_keep():
    """Two free bodies whose pair the model excludes only ever touch the floor: converted."""
    spec = _ball_world(self_collide=True)
    spec.add_exclude(bodyname1="other", bodyname2="ball")
    spec.add_exclude(bodyname1="other", bodyname2="arm")
    model = spec.copy().compile()
    assert all(model.geom_bodyid[a] == 0 for a, _ in candidate_pairs(model))
    assert explicit_pairs(spec)
    assert spec.compile().npair == len(candidate_pairs(model)) == 6

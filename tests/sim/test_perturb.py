"""Perturbed worlds: each edit does what its label says, batched variants equal single
runs, and the payload edit matches MuJoCo's own compile of a payload geom."""

import mujoco
import numpy as np
import pytest

from app.jobs.recovery.sequences import plan_hexapod
from app.jobs.recovery.run import nominal_params
from app.robots.catalog import JETHEXA
from app.robots.damage import DamageSpec
from app.jobs.recovery.evaluate import GaitEvaluator, SimConfig
from app.sim.perturb import NOMINAL, Perturbation, edit_model, perturbed_model, same_signature
from app.jobs.recovery.cases import perturbation, walking_cases
from app.jobs.recovery.robust import MultiModelEvaluator, aggregate, case_models

MASS = JETHEXA.geometry.total_mass
CASES = walking_cases(MASS)
SHORT = SimConfig(duration_s=1.0, settle_s=0.3)


@pytest.fixture(scope="module")
def world():
    return JETHEXA.model(DamageSpec(lost_legs=(1, 6)))


def test_each_case_edits_what_it_says(world):
    mspec, m = world
    c = {p.name: perturbed_model(mspec, p, m) for p in CASES}
    assert c["dt_half"].opt.timestep == pytest.approx(m.opt.timestep / 2)
    assert c["dt_quarter"].opt.timestep == pytest.approx(m.opt.timestep / 4)
    np.testing.assert_allclose(c["friction_0.7"].geom_friction[:, 0], 0.7 * m.geom_friction[:, 0])
    np.testing.assert_allclose(c["friction_1.3"].geom_friction[:, 0], 1.3 * m.geom_friction[:, 0])
    np.testing.assert_allclose(c["mass_+10pct"].body_mass, 1.1 * m.body_mass)
    assert c["mass_+10pct"].body_subtreemass[1] == pytest.approx(1.1 * m.body_subtreemass[1])  # mj_setConst ran
    pay = perturbation("payload", MASS).payload_kg
    assert c["payload"].body_subtreemass[0] == pytest.approx(m.body_subtreemass[0] + pay)
    rough = c["rough_terrain"]
    floor = mujoco.mj_name2id(rough, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    assert rough.geom_type[floor] == mujoco.mjtGeom.mjGEOM_HFIELD and rough.nhfield == 1
    assert np.ptp(rough.hfield_data) > 0.5  # normalised heights really vary
    # the nominal model is left alone
    assert m.opt.timestep == JETHEXA.geometry.timestep and m.geom_friction[0, 0] == 1.0
    same = [p.name for p in CASES if same_signature(c[p.name], m)]
    assert same == ["friction_0.7", "friction_1.3", "mass_+10pct", "payload"]


def test_payload_edit_matches_a_compiled_payload_geom():
    """Reference: MuJoCo's compiler adding a point-like payload geom to the torso."""
    p = Perturbation("p", "p", payload_kg=0.3, payload_offset_m=(0.02, -0.01, 0.005))
    mspec, m = JETHEXA.model()
    edited = edit_model(m, p)
    ref_spec = mspec.copy()
    torso = ref_spec.body("torso")
    com = m.body_ipos[1]
    torso.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[1e-4, 0, 0], mass=0.3,
                   pos=(com + np.array(p.payload_offset_m)).tolist(), contype=0, conaffinity=0)
    ref = ref_spec.compile()
    b = 1
    assert edited.body_mass[b] == pytest.approx(ref.body_mass[b])
    np.testing.assert_allclose(edited.body_ipos[b], ref.body_ipos[b], atol=1e-9)

    def tensor(model):
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, model.body_iquat[b])
        R = R.reshape(3, 3)
        return R @ np.diag(model.body_inertia[b]) @ R.T

    np.testing.assert_allclose(tensor(edited), tensor(ref), rtol=1e-5, atol=1e-9)


def test_variants_in_one_rollout_equal_single_model_runs(world):
    mspec, m = world
    cases = [NOMINAL] + walking_cases(MASS, ["friction_0.7", "payload", "dt_half", "rough_terrain"])
    models = case_models(mspec, m, cases)
    seq = plan_hexapod((1, 6), JETHEXA.nominal_feet_xy())
    legs = [2, 3, 4, 5]
    x = np.stack([nominal_params(JETHEXA, legs)] * 2)
    x[1, -2] = 0.03
    multi = MultiModelEvaluator(JETHEXA, models, seq, SHORT)
    assert multi.groups == [[0, 1, 2], [3], [4]]  # same-signature models share a rollout call
    r = multi.evaluate_all(x)
    for k, model in enumerate(models):
        single = GaitEvaluator(JETHEXA, model, seq, SHORT).evaluate(x).metrics
        for key, v in single.items():
            np.testing.assert_array_equal(r.metrics[key][:, k], v)
    # the perturbations change the outcome (these are real re-simulations)
    assert len({float(v) for v in r.metrics["y_f_m"][0]}) == len(models)
    multi.close()


def test_aggregates():
    f = np.array([[1.0, 3.0], [2.0, -1.0]])
    np.testing.assert_array_equal(aggregate(f, "mean"), [2.0, 0.5])
    np.testing.assert_array_equal(aggregate(f, "worst"), [1.0, -1.0])
    with pytest.raises(ValueError):
        aggregate(f, "best")

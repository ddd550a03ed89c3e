"""The heavy-duty hexapod of paper 002: mass, Eq. 1 foot workspace, standing margins."""

import mujoco
import numpy as np
import pytest

from app.robots.heavy_hexapod import HEAVY, JOINT_NAMES, LEG_IDS, build_cliff_spec, build_tilt_spec, joint_name
from app.jobs.tipping.stability.foothold import leg_fk


def test_mass_and_layout():
    m = build_tilt_spec().compile()
    torso = m.body("torso").id
    assert m.body_subtreemass[torso] == pytest.approx(5000.0)  # 4.4 t body + 6 x 0.1 t legs
    assert m.body_mass[torso] == pytest.approx(4400.0)
    assert m.nu == 6 * 3 * 2 + 1  # PID + feed-forward per joint, and the platform servo
    # Legs 1-3 left (+y) front to rear, 4-6 right; nominal footholds of Sec. 5.2.
    for leg in LEG_IDS:
        p = HEAVY.nominal_foot(leg)
        assert np.sign(p[1]) == (1 if leg <= 3 else -1)
        assert p[0] == pytest.approx((2.4, 0.0, -2.4)[(leg - 1) % 3])
    build_cliff_spec().compile()


def test_mujoco_feet_follow_eq1():
    spec = build_tilt_spec()
    m = spec.compile()
    d = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = {}
        for leg in LEG_IDS:
            ws = HEAVY.workspace(leg)
            q[leg] = (rng.uniform(*ws.theta_range), rng.uniform(*ws.x_range), rng.uniform(*ws.d_range))
            for jn, v in zip(JOINT_NAMES, q[leg]):
                d.joint(joint_name(leg, jn)).qpos = v
        mujoco.mj_forward(m, d)
        R = d.body("torso").xmat.reshape(3, 3)
        for leg in LEG_IDS:
            th, x, dd = q[leg]
            body = R.T @ (d.site(f"leg{leg}_tip").xpos - d.body("torso").xpos)
            np.testing.assert_allclose(body, leg_fk(HEAVY.workspace(leg), x, dd, th), atol=1e-9)


def test_describe_is_json_and_matches_the_model():
    import json

    from app.robots.heavy_hexapod import describe

    d = json.loads(json.dumps(describe()))
    assert d["name"] == "heavy_hexapod" and d["total_mass_kg"] == pytest.approx(5000.0)
    assert d["leg_sides"]["1"] == "left" and d["leg_sides"]["4"] == "right"

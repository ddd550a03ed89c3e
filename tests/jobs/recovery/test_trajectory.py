"""Eq. 3 in phase form equals Eq. 3 as typeset (sample index k) wherever the latter is defined."""

import numpy as np
import pytest

from app.jobs.recovery.sequences import GaitSequence
from app.jobs.recovery.trajectory import param_names, tip_positions


def eq3_typeset(y0, x0, z0, Lsl, Lsh, Lsd, H0, sigma, Ng):
    out = []
    for k in range(1, Ng + 1):
        if k <= Ng // sigma:
            y = y0 - 0.5 * Lsl * np.cos(sigma * np.pi / Ng * (k - 1))
            z = z0 + 0.5 * Lsh * (1 - np.cos(2 * sigma * np.pi / Ng * (k - 1))) - H0
        else:
            y = y0 + 0.5 * Lsl * np.cos(sigma * np.pi / ((sigma - 1) * Ng) * (k - Ng / sigma - 1))
            z = z0 + 0.5 * Lsd * (1 - np.cos(2 * sigma * np.pi / ((sigma - 1) * Ng) * (k - Ng / sigma - 1))) - H0
        out.append((x0, y, z))
    return np.array(out)


@pytest.mark.parametrize("sigma", [2, 3, 4])
def test_phase_form_equals_typeset_eq3(sigma):
    Ng, T = 120, 0.6
    legs = [1, 2]
    seq = GaitSequence("t", sigma, {1: 0, 2: 1})
    params = np.array([[0.02, -0.01, 0.11, 0.1, 0.04, 0.03]])
    t = np.arange(Ng) * T / Ng
    got = tip_positions(params, legs, seq, t, T, stance_height=0.1, step_depth=0.005)[0]
    ref = eq3_typeset(0.02, 0.11, 0.0, 0.04, 0.03, 0.005, 0.1, sigma, Ng)
    np.testing.assert_allclose(got[:, 0], ref, atol=1e-12)
    # Leg 2 swings one phase later: its trajectory is leg 1's shifted by Ng / sigma.
    ref2 = eq3_typeset(-0.01, 0.1, 0.0, 0.04, 0.03, 0.005, 0.1, sigma, Ng)
    np.testing.assert_allclose(got[:, 1], np.roll(ref2, Ng // sigma, axis=0), atol=1e-12)


def test_param_names_follow_eq4():
    assert param_names([2, 3]) == ["y0_leg2", "y0_leg3", "x0_leg2", "x0_leg3", "step_length", "step_height"]


def test_bad_param_width_is_rejected():
    seq = GaitSequence("t", 2, {1: 0, 2: 1})
    with pytest.raises(ValueError, match="expected 6"):
        tip_positions(np.zeros((1, 5)), [1, 2], seq, np.zeros(3), 0.6, 0.1)

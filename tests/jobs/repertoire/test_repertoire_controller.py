"""The periodic joint-space controller: every set-point within its joint's range, the
stance before the gait, the single-tick helper the robot calls equal to the batch, and the
parameter count 3 n + 1."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from app.jobs.repertoire.controller import Layout, n_params

unit = st.floats(0.0, 1.0, allow_nan=False)


@st.composite
def layouts(draw):
    n = draw(st.integers(1, 8))
    lo = draw(arrays(float, n, elements=st.floats(-3.0, 0.0)))
    width = draw(arrays(float, n, elements=st.floats(0.01, 4.0)))
    stance = draw(arrays(float, n, elements=st.floats(-4.0, 4.0)))  # may lie outside the range: clipped
    p_lo = draw(st.floats(0.05, 2.0))
    return Layout(lo, lo + width, stance, draw(st.floats(0.01, 1.0)), draw(st.floats(0.0, 1.0)),
                  (p_lo, p_lo + draw(st.floats(0.01, 3.0))), draw(st.floats(0.0, 2.0)))


@settings(max_examples=60, deadline=None)
@given(layout=layouts(), data=st.data())
def test_set_points_stay_within_the_joint_ranges(layout, data):
    P = data.draw(st.integers(1, 4))
    x = data.draw(arrays(float, (P, layout.dim), elements=st.floats(-0.5, 1.5)))  # outside the cube: clipped
    t = data.draw(arrays(float, data.draw(st.integers(1, 20)), elements=st.floats(-1.0, 30.0)))
    q = layout.setpoints(x, t)
    assert q.shape == (P, t.size, layout.n_joints)
    assert np.all(q >= layout.lo) and np.all(q <= layout.hi)
    before = t < 0
    assert np.array_equal(q[:, before], np.broadcast_to(layout.stance, q[:, before].shape))
    k = data.draw(st.integers(0, t.size - 1))
    np.testing.assert_array_equal(layout.setpoints_single(x[0], t[k]), q[0, k])


def test_terms_follow_the_stated_layout():
    layout = Layout([-1.0, -2.0], [1.0, 0.0], [0.0, -1.0], amplitude=0.5, offset=0.25, period_s=(0.4, 1.2))
    assert layout.dim == n_params(2) == 7
    x = np.array([[1.0, 0.25, 1.0, 0.0, 0.5, 0.0, 0.5]])
    amp, phase, centre, period = layout.terms(x)
    np.testing.assert_allclose(amp, [[0.5, 0.0]])
    np.testing.assert_allclose(phase, [[0.25, 0.5]])
    np.testing.assert_allclose(centre, [[0.25, -1.25]])
    np.testing.assert_allclose(period, [0.8])
    # no fade-in: at t = 0 the first joint is at its centre plus amp sin(2 pi 0.25)
    np.testing.assert_allclose(layout.setpoints(x, np.array([0.0]))[0, 0], [0.75, -1.25])
    again = Layout.from_json(layout.to_json())
    np.testing.assert_array_equal(again.setpoints(x, np.linspace(0, 2, 9)), layout.setpoints(x, np.linspace(0, 2, 9)))

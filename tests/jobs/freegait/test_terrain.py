"""Heightfield and minefield from seeds."""

import mujoco
import numpy as np
import pytest

from app.robots import silo6
from app.jobs.freegait.terrain import add_heightfield, make_minefield, make_terrain


def test_heightfield_matches_the_height_function():
    ter = make_terrain((-1.0, 2.0), (-1.0, 1.0), 0.04, seed=3)
    assert ter.heights.min() == pytest.approx(0.0) and ter.heights.max() == pytest.approx(0.04)
    spec = silo6.base_spec()
    add_heightfield(spec, ter, friction=0.9)
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-0.9, 1.9, 40), rng.uniform(-0.9, 0.9, 40)])
    gid = np.zeros(1, dtype=np.int32)
    for p in pts:
        dist = mujoco.mj_ray(m, d, np.array([p[0], p[1], 1.0]), np.array([0, 0, -1.0]), None, 1, -1, gid)
        # MuJoCo triangulates each cell; bilinear interpolation differs by far less than the roughness.
        assert 1.0 - dist == pytest.approx(float(ter.height(p)), abs=2e-3)


def test_same_seed_same_field_and_cleared_start():
    ter = make_terrain((-1.0, 3.0), (-1.5, 1.5), 0.04, seed=0)
    cleared = np.array([[0.365, 0.57], [0.0, -0.57]])
    a = make_minefield(ter, 5.0, 0.05, 0.15, seed=7, cleared=cleared)
    b = make_minefield(ter, 5.0, 0.05, 0.15, seed=7, cleared=cleared)
    np.testing.assert_array_equal(a.centres, b.centres)
    assert len(a.centres) > 30  # ~5 per m^2 over 12 m^2
    assert not a.in_safe_area(cleared).any()
    c = make_minefield(ter, 5.0, 0.05, 0.15, seed=8)
    assert len(c.centres) != len(a.centres) or not np.array_equal(c.centres, a.centres)
    assert make_minefield(ter, 0.0, 0.05, 0.15, seed=7).centres.shape == (0, 2)
    assert a.in_zone(a.centres[:1] + [0.02, 0]).all() and not a.in_zone(a.centres[:1] + [0.03, 0]).any()

"""Modular robot shapes (paper 001, Fig. 3): structure, stuck modules, resting physics."""

import mujoco
import numpy as np
import pytest

from app.robots.modular import SHAPES, build_model, functional_modules


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_shape_is_a_connected_grid_tree(name):
    shape = SHAPES[name]
    cells = [m.cell for m in shape.modules]
    assert len(set(cells)) == len(cells)
    assert shape.modules[0].parent == -1 and shape.modules[0].cell == (0, 0)
    for i, m in enumerate(shape.modules[1:], start=1):
        assert 0 <= m.parent < i
        pc = shape.modules[m.parent].cell
        assert abs(pc[0] - m.cell[0]) + abs(pc[1] - m.cell[1]) == 1  # touches its parent
        assert m.hinge in ("z", "h")
    assert len(set(shape.failures)) == 2 and 0 < min(shape.failures) and max(shape.failures) < shape.m


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_one_actuated_hinge_per_working_module(name):
    shape = SHAPES[name]
    _, model = build_model(shape)
    assert model.nu == shape.m and model.njnt == shape.m + 1
    stuck = shape.failures
    _, dm = build_model(shape, stuck)
    assert dm.nu == shape.m - 2
    names = {mujoco.mj_id2name(dm, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(dm.njnt)}
    for s in stuck:
        assert f"hinge{s}" not in names
    assert functional_modules(shape, stuck) == [i for i in range(shape.m) if i not in stuck]


def test_unknown_stuck_module_is_rejected():
    with pytest.raises(ValueError, match="stuck module 9"):
        build_model(SHAPES["lizard"], (9,))


@pytest.mark.parametrize("name", ["lizard", "quadropod"])
def test_robot_rests_still_with_zero_setpoints(name):
    _, m = build_model(SHAPES[name])
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    start = d.site("pivot").xpos.copy()
    for _ in range(200):
        mujoco.mj_step(m, d)
    assert np.linalg.norm(d.site("pivot").xpos - start) < 2e-3
    assert abs(d.site("pivot").xpos[2] - 0.05) < 2e-3  # the module centre half a cube above the floor

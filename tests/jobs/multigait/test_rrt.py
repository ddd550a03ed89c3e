"""RRT-MP invariants (paper 001, Alg. 1): connectivity, pruning rule, coverage, obstacles."""

import numpy as np
import pytest

from app.jobs.multigait.planner.costs import planner_draws
from app.jobs.multigait.planner.maps import CollisionGrid, get_map, point_clearance
from app.jobs.multigait.planner.primitives import Primitives
from app.jobs.multigait.planner.rrt import composed_expander, path_to, rrt_mp


def synthetic_primitives(B, k, seed, S=21, scale=3.0):
    """Arcs: each gait drives forward-ish with a constant turn rate."""
    rng = np.random.default_rng(seed)
    length = rng.uniform(0.2, scale, (B, k))
    heading = rng.uniform(-np.pi, np.pi, (B, k))
    turn = rng.uniform(-1.0, 1.0, (B, k))
    s = np.linspace(0, 1, S)
    ang = heading[..., None] + turn[..., None] * s * 0.5
    step = length[..., None] / (S - 1)
    dx = np.concatenate([np.zeros((B, k, 1)), np.cumsum(step * np.cos(ang[..., 1:]), axis=-1)], axis=-1)
    dy = np.concatenate([np.zeros((B, k, 1)), np.cumsum(step * np.sin(ang[..., 1:]), axis=-1)], axis=-1)
    path = np.stack([dx, dy, np.full_like(dx, 0.5)], axis=-1)
    return Primitives(end_xy=path[:, :, -1, :2].copy(), dyaw=turn, path=path)


def grow(map_name="column", B=6, k=3, K=80, seed=0, radius=2.0):
    pmap = get_map(map_name)
    prims = synthetic_primitives(B, k, seed)
    tree = rrt_mp(pmap, composed_expander(prims), k, planner_draws(seed, B, K), radius,
                  record_paths=True, path_len=prims.path.shape[2])
    return pmap, prims, tree


@pytest.mark.parametrize("map_name", ["empty", "column"])
def test_tree_is_connected_and_edges_are_gaits(map_name):
    pmap, prims, tree = grow(map_name)
    for b in range(tree.pos.shape[0]):
        t = tree.single(b)
        n = len(t["pos"])
        assert n > 10
        assert t["parent"][0] == -1
        for i in range(1, n):
            p, j = t["parent"][i], t["gait"][i]
            assert 0 <= p < i and 0 <= j < prims.k
            th = t["yaw"][p]
            c, s = np.cos(th), np.sin(th)
            e = prims.end_xy[b, j]
            assert np.allclose(t["pos"][i, :2], t["pos"][p, :2] + [c * e[0] - s * e[1], s * e[0] + c * e[1]])
            assert np.isclose(t["yaw"][i], th + prims.dyaw[b, j])
            assert path_to(t, i)[0] == 0


def test_pruning_rule_holds_for_every_node():
    _, _, tree = grow("empty", K=120)
    for b in range(tree.pos.shape[0]):
        t = tree.single(b)
        for i in range(1, len(t["pos"])):
            p = t["parent"][i]
            d_parent = np.linalg.norm(t["pos"][i, :2] - t["pos"][p, :2])
            others = np.array([q for q in range(i) if q != p])
            if others.size:
                d_other = np.linalg.norm(t["pos"][others, :2] - t["pos"][i, :2], axis=1).min()
                assert d_other > d_parent  # closer to its parent than to any earlier node


def test_pruning_rejects_a_child_near_another_node():
    # one gait going +x by 1 and one going -x by 1 from the root, then the +x child's
    # -x gait lands on the root: it must be pruned (closer to the root than to its parent? tie)
    S = 3
    path = np.zeros((1, 2, S, 3))
    path[0, 0, :, 0] = [0, 0.5, 1.0]
    path[0, 1, :, 0] = [0, -0.5, -1.0]
    prims = Primitives(end_xy=path[:, :, -1, :2].copy(), dyaw=np.zeros((1, 2)), path=path)
    pmap = get_map("empty")
    tree = rrt_mp(pmap, composed_expander(prims), 2, planner_draws(1, 1, 200), 1.0)
    t = tree.single(0)
    xs = np.round(t["pos"][:, 0] - pmap.start[0], 9)
    assert len(np.unique(xs)) == len(xs)  # never two nodes on the same spot
    assert np.allclose(t["pos"][:, 1], pmap.start[1])


def test_coverage_is_the_share_of_cells_with_nodes():
    pmap, _, tree = grow("empty")
    cov = tree.coverage()
    assert np.all((cov >= 0) & (cov <= 1))
    for b in range(tree.pos.shape[0]):
        t = tree.single(b)
        cells = {(int(np.floor(y)), int(np.floor(x))) for x, y in t["pos"][:, :2]}
        assert cov[b] == pytest.approx(len(cells) / (48 * 27))


def test_obstacles_are_never_crossed():
    radius = 2.0
    pmap, _, tree = grow("column", B=8, K=150, seed=3, radius=radius)
    for b in range(tree.pos.shape[0]):
        t = tree.single(b)
        clear = point_clearance(pmap, t["paths"][1:, :, :2].reshape(-1, 2))
        assert clear.min() >= radius
    # and the column does block: without the obstacle some swept samples would enter it
    grid = CollisionGrid(pmap, radius)
    assert grid.blocked(np.array([[24.0, 13.5], [24.0, 25.9], [1.0, 13.0]])).all()
    assert not grid.blocked(np.array([[10.0, 13.5]])).any()


def test_same_draws_same_tree_other_draws_other_tree():
    _, _, a = grow("empty", seed=2)
    _, _, b = grow("empty", seed=2)
    assert np.array_equal(a.pos, b.pos) and np.array_equal(a.parent, b.parent)
    pmap = get_map("empty")
    prims = synthetic_primitives(6, 3, 2)
    c = rrt_mp(pmap, composed_expander(prims), 3, planner_draws(99, 6, 80), 2.0)
    assert not np.array_equal(a.pos, c.pos)


def test_stationary_gaits_add_nothing():
    prims = synthetic_primitives(2, 3, 0, scale=3.0)
    prims.end_xy[:] = 0.0
    prims.path[..., :2] = 0.0
    prims.dyaw[:] = 0.0
    tree = rrt_mp(get_map("empty"), composed_expander(prims), 3, planner_draws(0, 2, 30), 2.0)
    assert np.all(tree.n == 1)
    assert np.allclose(tree.coverage(), 1 / (48 * 27))

"""RRT-MP with flood-fill expansion and node pruning (paper 001, Alg. 1), batched.

B independent trees (one per PSO particle, or one per reuse plan) grow in lock step: each
iteration draws one random point per tree, finds each tree's nearest node, expands it
with all k gaits of that tree at once (composed from cached primitives, or simulated in one
rollout on the staircase) and adds the results that pass the collision and pruning tests.
Only k (the gait loop of Alg. 1, line 6) is a Python loop inside an iteration.

Pruning (line 9). As typeset the test compares q_new's nearest tree node q' with q_near,
which is itself in the tree, so it could never pass; the intent (Fig. 2: "pruned if they
approach other nodes in the tree closer than their parent node") is that q' is the nearest
node *other than* q_near: q_new is added iff it is strictly closer to its parent than to
any other node, counting siblings added earlier in the same iteration. A gait that leaves
the pivot within ``min_move`` of its parent adds nothing (a duplicate node covers nothing).

Metric rho: the pivot's planar distance (x, y); on non-flat maps (stairs) its 3-D distance.
The random configuration is a uniform point of the map (the metric ignores the rest).
Collisions: every swept sample of the pivot must be free in the map's CollisionGrid.
Coverage: the share of the map's cells that hold at least one tree node (Sec. IV-B: "the
nodes of the tree are assigned to cells according to their 2D positions").
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np

from app.jobs.multigait.planner.maps import CollisionGrid, PlanMap
from app.jobs.multigait.planner.primitives import Primitives


@dataclasses.dataclass
class Tree:
    pos: np.ndarray  # (B, N, 3) pivot centre, mu
    yaw: np.ndarray  # (B, N)
    parent: np.ndarray  # (B, N) int, -1 for the root and unused slots
    gait: np.ndarray  # (B, N) int, the gait that created the node (-1 root)
    n: np.ndarray  # (B,) nodes in use
    covered: np.ndarray  # (B, ny, nx) bool
    states: np.ndarray | None = None  # (B, N, nstate) full physics states (simulated trees)
    paths: np.ndarray | None = None  # (B, N, S, 3) swept pivot path into each node (recorded)

    def coverage(self) -> np.ndarray:
        return self.covered.reshape(self.covered.shape[0], -1).mean(axis=1)

    def goal_distance(self, goal, planar: bool = True) -> np.ndarray:
        g = np.asarray(goal, dtype=float)
        d = self.pos[..., :2] - g[:2] if planar else self.pos - g
        dist = np.linalg.norm(d, axis=-1)
        used = np.arange(self.pos.shape[1])[None] < self.n[:, None]
        return np.where(used, dist, np.inf).min(axis=1)

    def single(self, b: int) -> dict:
        n = int(self.n[b])
        out = {"pos": self.pos[b, :n], "yaw": self.yaw[b, :n], "parent": self.parent[b, :n],
               "gait": self.gait[b, :n], "covered": self.covered[b]}
        if self.paths is not None:
            out["paths"] = self.paths[b, :n]
        if self.states is not None:
            out["states"] = self.states[b, :n]
        return out


# An expander maps (tree, near (B,)) to the k children of each tree's near node:
# swept pivot paths (B, k, S, 3) in world mu (start included), end headings (B, k) and
# end states (B, k, nstate) or None.
Expander = Callable[[Tree, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray | None]]


def composed_expander(prims: Primitives) -> Expander:
    """Flat maps: place each tree's cached gait paths at the near node's pose."""

    def expand(tree: Tree, near: np.ndarray):
        b = np.arange(tree.pos.shape[0])
        x, y, th = tree.pos[b, near, 0], tree.pos[b, near, 1], tree.yaw[b, near]
        c, s = np.cos(th)[:, None, None], np.sin(th)[:, None, None]
        lx, ly = prims.path[..., 0], prims.path[..., 1]
        wx = x[:, None, None] + c * lx - s * ly
        wy = y[:, None, None] + s * lx + c * ly
        return np.stack([wx, wy, prims.path[..., 2]], axis=-1), th[:, None] + prims.dyaw, None

    return expand


def simulated_expander(sim, ctrl: np.ndarray) -> Expander:
    """Any map: run each tree's k gaits (``ctrl`` (B, k, nstep, nu)) from the near node's
    full state, all B * k in one rollout."""
    B, k = ctrl.shape[:2]
    flat_ctrl = ctrl.reshape(B * k, *ctrl.shape[2:])

    def expand(tree: Tree, near: np.ndarray):
        b = np.arange(B)
        st = np.repeat(tree.states[b, near], k, axis=0)
        xyz, yaw, end, _ = sim.rollout(st, flat_ctrl)
        return xyz.reshape(B, k, *xyz.shape[1:]), yaw[:, -1].reshape(B, k), end.reshape(B, k, -1)

    return expand


def rrt_mp(pmap: PlanMap, expand: Expander, k: int, draws: np.ndarray, radius: float,
           root_pose: np.ndarray | None = None, root_state: np.ndarray | None = None,
           record_paths: bool = False, path_len: int = 0, min_move: float = 1e-3) -> Tree:
    """Grow B trees for K iterations. ``draws`` (B, K, 2) are the random points in [0, 1)^2
    (scaled to the map here); the root is the map's start (pivot z from ``root_pose`` if
    given, (x, y, z, yaw))."""
    B, K = draws.shape[:2]
    N = 1 + K * k
    grid = collision_grid(pmap, float(radius))
    ny, nx = pmap.shape
    planar = pmap.flat
    if root_pose is None:
        root_pose = np.array([pmap.start[0], pmap.start[1], 0.5, pmap.start[2]])
    tree = Tree(pos=np.zeros((B, N, 3)), yaw=np.zeros((B, N)), parent=np.full((B, N), -1),
                gait=np.full((B, N), -1), n=np.ones(B, dtype=np.int64), covered=np.zeros((B, ny, nx), dtype=bool))
    tree.pos[:, 0] = root_pose[:3]
    tree.yaw[:, 0] = root_pose[3]
    if root_state is not None:
        tree.states = np.zeros((B, N, root_state.shape[-1]))
        tree.states[:, 0] = root_state
    if record_paths:
        tree.paths = np.zeros((B, N, path_len, 3))
        tree.paths[:, 0] = root_pose[:3]
    _mark(tree.covered, np.arange(B), tree.pos[:, :1], pmap)
    b = np.arange(B)
    dims = 2 if planar else 3
    for it in range(K):
        m = int(tree.n.max())  # only the used prefix of the node arrays is searched
        pos = tree.pos[:, :m]
        used = np.arange(m)[None] < tree.n[:, None]
        q_rand = draws[:, it] * (pmap.width, pmap.height)
        d2 = (pos[..., 0] - q_rand[:, :1]) ** 2 + (pos[..., 1] - q_rand[:, 1:]) ** 2
        near = np.argmin(np.where(used, d2, np.inf), axis=1)
        paths, yaw_end, st_end = expand(tree, near)
        free = ~grid.blocked(paths[..., :2]).any(axis=-1)  # (B, k)
        parent_pos = tree.pos[b, near, :dims]
        for j in range(k):
            q_new = paths[:, j, -1]
            m = int(tree.n.max())
            diff = tree.pos[:, :m, :dims] - q_new[:, None, :dims]
            d2 = np.einsum("bnd,bnd->bn", diff, diff)
            others = np.arange(m)[None] < tree.n[:, None]
            others[b, near] = False
            d_other = np.where(others, d2, np.inf).min(axis=1)
            dp = q_new[:, :dims] - parent_pos
            d_parent = np.einsum("bd,bd->b", dp, dp)
            add = free[:, j] & (d_other > d_parent) & (d_parent > min_move * min_move)
            if not add.any():
                continue
            ba, slot = b[add], tree.n[add]
            tree.pos[ba, slot] = q_new[add]
            tree.yaw[ba, slot] = yaw_end[add, j]
            tree.parent[ba, slot] = near[add]
            tree.gait[ba, slot] = j
            if tree.states is not None:
                tree.states[ba, slot] = st_end[add, j]
            if tree.paths is not None:
                tree.paths[ba, slot] = paths[add, j]
            tree.n[add] += 1
            _mark(tree.covered, ba, q_new[add, None], pmap)
    return tree


@functools.lru_cache(maxsize=32)
def collision_grid(pmap: PlanMap, radius: float) -> CollisionGrid:
    return CollisionGrid(pmap, radius)


def _mark(covered: np.ndarray, bidx: np.ndarray, pts: np.ndarray, pmap: PlanMap) -> None:
    """Set the cells under points pts (len(bidx), S, >=2) of trees bidx."""
    ny, nx = covered.shape[1:]
    ix = np.floor(pts[..., 0] / pmap.cell).astype(np.int64)
    iy = np.floor(pts[..., 1] / pmap.cell).astype(np.int64)
    ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    bb = np.broadcast_to(bidx[:, None], ix.shape)
    covered[bb[ok], iy[ok], ix[ok]] = True


def path_to(tree: dict, node: int) -> list[int]:
    """Node indices from the root to ``node`` of a single tree (``Tree.single``)."""
    out = [node]
    while tree["parent"][out[-1]] >= 0:
        out.append(int(tree["parent"][out[-1]]))
    return out[::-1]

"""Planning maps of paper 001 (Sec. V): Empty and Column (48 x 27 mu) and a staircase.

Coordinates are map units (mu, one module edge), x right, y up, the map's lower-left corner
at the origin. ``obstacles`` are axis-aligned rectangles the robot must not touch; they are
checked by the planner on the swept path of the pivot, inflated by the robot's footprint
radius (the robot turns, so its bounding circle is the footprint that holds for every
heading). The map border is a wall of the same kind. ``terrain`` is physical (stairs):
simulated by MuJoCo, not forbidden.

Choices where the paper is silent: the column is a 4 x 4 mu block in the middle; the robot
starts 10 mu left of the centre facing +x and the distance-cost goal is 15 mu ahead of it,
behind the column. The staircase has 5 steps of 0.6 mu with 3 mu treads up to a plateau,
the goal on the plateau.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.robots.modular import Terrain

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (mu)


@dataclasses.dataclass(frozen=True)
class PlanMap:
    name: str
    width: float = 48.0
    height: float = 27.0
    obstacles: tuple[Rect, ...] = ()
    terrain: Terrain = Terrain()
    start: tuple[float, float, float] = (14.0, 13.5, 0.0)  # x, y, yaw (rad)
    goal: tuple[float, float, float] = (29.0, 13.5, 0.5)  # x, y, z (mu) of the pivot centre
    cell: float = 1.0  # coverage cell edge (mu)
    flat: bool = True  # a gait's displacement does not depend on where it starts

    @property
    def shape(self) -> tuple[int, int]:
        return int(round(self.height / self.cell)), int(round(self.width / self.cell))

    def with_start_goal(self, start, goal) -> PlanMap:
        return dataclasses.replace(self, start=tuple(float(v) for v in start), goal=tuple(float(v) for v in goal))

    def describe(self) -> dict:
        return {"name": self.name, "width_mu": self.width, "height_mu": self.height,
                "obstacles": [list(r) for r in self.obstacles],
                "terrain_boxes": [[list(c), list(h)] for c, h in self.terrain.boxes],
                "start": list(self.start), "goal": list(self.goal), "cell_mu": self.cell, "flat": self.flat}

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Terrain height (mu) under points, for drawing and goal placement."""
        z = np.zeros(np.broadcast(x, y).shape)
        for (cx, cy, cz), (hx, hy, hz) in self.terrain.boxes:
            inside = (np.abs(x - cx) <= hx) & (np.abs(y - cy) <= hy)
            z = np.where(inside, np.maximum(z, cz + hz), z)
        return z


class CollisionGrid:
    """Free/forbidden raster of the map for a pivot whose robot has footprint radius ``r``.

    A sample point is forbidden if it lies within r (+ half a raster cell, so the raster is
    conservative) of an obstacle or of the border."""

    def __init__(self, pmap: PlanMap, radius: float, res: float = 0.25):
        self.pmap, self.radius, self.res = pmap, float(radius), float(res)
        nx, ny = int(np.ceil(pmap.width / res)), int(np.ceil(pmap.height / res))
        xs = (np.arange(nx) + 0.5) * res
        ys = (np.arange(ny) + 0.5) * res
        X, Y = np.meshgrid(xs, ys)
        margin = self.radius + 0.5 * res * np.sqrt(2.0)
        bad = (X < margin) | (X > pmap.width - margin) | (Y < margin) | (Y > pmap.height - margin)
        for x0, y0, x1, y1 in pmap.obstacles:
            dx = np.maximum(np.maximum(x0 - X, X - x1), 0.0)
            dy = np.maximum(np.maximum(y0 - Y, Y - y1), 0.0)
            bad |= np.hypot(dx, dy) < margin
        self.bad = bad
        self.nx, self.ny = nx, ny
        # The raster's outer ring is always forbidden (margin > 0 from the border), so a point
        # outside the map can simply be clamped onto it.
        assert bad[0].all() and bad[-1].all() and bad[:, 0].all() and bad[:, -1].all()
        self._flat = bad.ravel()

    def blocked(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2) points -> (...) bool, True where forbidden (outside the map included)."""
        ix = np.clip(xy[..., 0] * (1.0 / self.res), 0.0, self.nx - 0.5).astype(np.int64)
        iy = np.clip(xy[..., 1] * (1.0 / self.res), 0.0, self.ny - 0.5).astype(np.int64)
        return self._flat[iy * self.nx + ix]


def point_clearance(pmap: PlanMap, xy: np.ndarray) -> np.ndarray:
    """Exact distance from points to the nearest obstacle or border (for checks)."""
    x, y = xy[..., 0], xy[..., 1]
    d = np.minimum(np.minimum(x, pmap.width - x), np.minimum(y, pmap.height - y))
    for x0, y0, x1, y1 in pmap.obstacles:
        dx = np.maximum(np.maximum(x0 - x, x - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - y, y - y1), 0.0)
        d = np.minimum(d, np.hypot(dx, dy))
    return d


def _stairs() -> PlanMap:
    boxes = []
    n, rise, tread, x0 = 5, 0.6, 3.0, 10.0
    for i in range(n):
        top = rise * (i + 1)
        xa = x0 + tread * i
        xb = 48.0 if i == n - 1 else xa + tread
        boxes.append(((0.5 * (xa + xb), 13.5, 0.5 * top), (0.5 * (xb - xa), 13.5, 0.5 * top)))
    return PlanMap(name="stairs", terrain=Terrain(tuple(boxes)), start=(6.0, 13.5, 0.0),
                   goal=(30.0, 13.5, rise * n + 0.5), flat=False)


MAPS: dict[str, PlanMap] = {
    "empty": PlanMap(name="empty"),
    "column": PlanMap(name="column", obstacles=((22.0, 11.5, 26.0, 15.5),)),
    "stairs": _stairs(),
}


def get_map(name: str) -> PlanMap:
    try:
        return MAPS[name]
    except KeyError:
        raise KeyError(f"unknown map {name!r}; known: {sorted(MAPS)}") from None

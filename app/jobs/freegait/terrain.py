"""Uneven ground as a MuJoCo heightfield, and forbidden zones (mines) on it, from seeds.

The ground is smooth random relief: white noise from the terrain seed, low-pass filtered
(Gaussian kernel of ``correlation_m``) and scaled so its heights span [0, roughness_m] —
roughness is the peak-to-valley height, the paper's "maximum height of irregularities".
Forbidden zones are a Poisson field of ``density_per_m2`` from their own seed (so the same
minefield can sit on different ground): circles of ``zone_diameter_m`` with a concentric
safe area of ``safe_diameter_m`` (Sec. 5.1, Fig. 9: a foot centre may stand on the safe
area's boundary, never inside a zone). Zones whose safe area would cover a foot of the
starting stance are dropped: the robot is put down on cleared ground, as a demining team
would.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np


@dataclasses.dataclass(frozen=True)
class Terrain:
    x_range: tuple[float, float]
    y_range: tuple[float, float]
    heights: np.ndarray  # (ny, nx) metres, row j at y = y0 + j * res, column i at x = x0 + i * res
    resolution: float
    roughness: float

    @property
    def nx(self) -> int:
        return self.heights.shape[1]

    @property
    def ny(self) -> int:
        return self.heights.shape[0]

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Ground height at points (..., 2) by bilinear interpolation (outside: clamped)."""
        xy = np.asarray(xy, dtype=float)
        fx = np.clip((xy[..., 0] - self.x_range[0]) / self.resolution, 0, self.nx - 1.000001)
        fy = np.clip((xy[..., 1] - self.y_range[0]) / self.resolution, 0, self.ny - 1.000001)
        i, j = np.floor(fx).astype(int), np.floor(fy).astype(int)
        u, v = fx - i, fy - j
        h = self.heights
        return ((1 - u) * (1 - v) * h[j, i] + u * (1 - v) * h[j, i + 1] + (1 - u) * v * h[j + 1, i]
                + u * v * h[j + 1, i + 1])

    def contains(self, xy: np.ndarray, margin: float = 0.0) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        return ((xy[..., 0] >= self.x_range[0] + margin) & (xy[..., 0] <= self.x_range[1] - margin)
                & (xy[..., 1] >= self.y_range[0] + margin) & (xy[..., 1] <= self.y_range[1] - margin))


@dataclasses.dataclass(frozen=True)
class Minefield:
    centres: np.ndarray  # (n, 2) world xy
    zone_radius: float
    safe_radius: float

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """Distance from points (..., 2) to the nearest zone centre (inf without zones)."""
        xy = np.asarray(xy, dtype=float)
        if len(self.centres) == 0:
            return np.full(xy.shape[:-1], np.inf)
        d = np.linalg.norm(xy[..., None, :] - self.centres, axis=-1)
        return d.min(axis=-1)

    def in_zone(self, xy: np.ndarray) -> np.ndarray:
        return self.distance(xy) < self.zone_radius

    def in_safe_area(self, xy: np.ndarray) -> np.ndarray:
        """Strictly inside a safe area (a zone included)."""
        return self.distance(xy) < self.safe_radius


def make_terrain(x_range: tuple[float, float], y_range: tuple[float, float], roughness: float, seed: int,
                 resolution: float = 0.02, correlation_m: float = 0.12) -> Terrain:
    nx = int(round((x_range[1] - x_range[0]) / resolution)) + 1
    ny = int(round((y_range[1] - y_range[0]) / resolution)) + 1
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7E77]))
    noise = rng.standard_normal((ny, nx))
    # Gaussian low-pass in the Fourier domain (periodic borders are harmless here).
    ky = np.fft.fftfreq(ny, d=resolution)[:, None]
    kx = np.fft.fftfreq(nx, d=resolution)[None, :]
    kernel = np.exp(-2.0 * (np.pi * correlation_m) ** 2 * (kx**2 + ky**2))
    field = np.real(np.fft.ifft2(np.fft.fft2(noise) * kernel))
    span = field.max() - field.min()
    heights = (field - field.min()) / span * roughness if (roughness > 0 and span > 0) else np.zeros_like(field)
    return Terrain(x_range=tuple(x_range), y_range=tuple(y_range), heights=heights, resolution=resolution,
                   roughness=float(roughness))


def make_minefield(terrain: Terrain, density_per_m2: float, zone_diameter: float, safe_diameter: float, seed: int,
                   cleared: np.ndarray | None = None) -> Minefield:
    """Poisson zones over the terrain. ``cleared`` (m, 2): points no safe area may cover."""
    (x0, x1), (y0, y1) = terrain.x_range, terrain.y_range
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x313E]))
    n = rng.poisson(density_per_m2 * (x1 - x0) * (y1 - y0))
    centres = np.column_stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)])
    if cleared is not None and len(centres):
        d = np.linalg.norm(centres[:, None, :] - np.asarray(cleared)[None, :, :], axis=-1).min(axis=1)
        centres = centres[d >= safe_diameter / 2]
    return Minefield(centres=centres, zone_radius=zone_diameter / 2, safe_radius=safe_diameter / 2)


def add_heightfield(spec: mujoco.MjSpec, terrain: Terrain, friction: float, name: str = "ground") -> None:
    """The terrain as an hfield geom whose lowest point is z = 0."""
    rx = (terrain.x_range[1] - terrain.x_range[0]) / 2
    ry = (terrain.y_range[1] - terrain.y_range[0]) / 2
    top = max(terrain.roughness, 1e-4)
    hf = spec.add_hfield(name=name, size=[rx, ry, top, 0.1], nrow=terrain.ny, ncol=terrain.nx,
                         userdata=(terrain.heights / top).astype(np.float32).reshape(-1).tolist())
    del hf
    spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname=name,
                            pos=[(terrain.x_range[0] + terrain.x_range[1]) / 2,
                                 (terrain.y_range[0] + terrain.y_range[1]) / 2, 0.0],
                            contype=0, conaffinity=1, friction=[friction, 0.005, 1e-4], rgba=[0.55, 0.5, 0.38, 1])


def add_zone_markers(spec: mujoco.MjSpec, terrain: Terrain, field: Minefield) -> None:
    """Zones and safe areas as thin non-colliding discs on the ground (for the replay only)."""
    if len(field.centres) == 0:
        return
    h = terrain.height(field.centres)
    for k, ((x, y), z) in enumerate(zip(field.centres, h)):
        spec.worldbody.add_geom(name=f"safe{k}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[field.safe_radius, 0.001, 0],
                                pos=[x, y, z + 0.003], contype=0, conaffinity=0, group=2, rgba=[0.5, 0.5, 0.5, 0.6])
        spec.worldbody.add_geom(name=f"zone{k}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[field.zone_radius, 0.002, 0],
                                pos=[x, y, z + 0.005], contype=0, conaffinity=0, group=2, rgba=[0.05, 0.05, 0.05, 1])

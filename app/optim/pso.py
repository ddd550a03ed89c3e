"""Particle swarm optimisation (paper 001, Eq. 1; Kennedy & Eberhart), ask/tell.

    v_ij(k+1) = w v_ij(k) + phi1 r1_j (xbar_ij - x_ij) + phi2 r2_j (xhat_j - x_ij)
    x_ij(k+1) = x_ij(k) + v_ij(k+1)

with r1, r2 ~ U(0, 1) drawn per particle and dimension.

Two coefficient sets (``PRESETS``):

* ``"constriction"`` (the default): Clerc & Kennedy's constriction coefficients in their
  inertia form, w = 0.7298, phi1 = phi2 = 1.49618 (SPSO 2006/2011), with |v| clamped to
  ``vmax`` = 0.2 of the box width.
* ``"paper"``: the paper's w = 0.1, phi1 = phi2 = 2 with |v| clamped to the box width.
  With these the swarm cannot converge: ignoring the small inertia, one step maps a
  particle's distance to its attractor by (1 - c) with c = phi1 r1 + phi2 r2, and
  E[(1 - c)^2] = 1 - 2 E[c] + E[c^2] = 1.67 > 1 (Poli's order-2 condition
  phi1 + phi2 < 24 (1 - w^2) / (7 - 5 w) = 3.66 is violated), so the spread grows by ~29 %
  per generation until the box walls stop it. Measured on the Lizard: 15-20 % of all
  coordinates sit on a wall in every generation and the swarm's spread stays at the
  uniform initial value: the search is a random search with a bias to the walls
  (docs/multigait.md).

The paper leaves open the initial velocities and how bounds are kept; we draw
v(0) ~ U(-(u - l), u - l) / 2 (scaled by ``vmax``), and clip positions to the box, zeroing
the velocity component that hit a wall (an "absorbing wall", so particles do not stick
to it with a velocity pointing outward). Maximises; the state (positions, velocities,
personal and global bests, generator state) is a JSON-able dict, so a restored run
continues bit-identically.
"""

from __future__ import annotations

import numpy as np

from app.optim.base import Optimizer, as_array, as_list

PRESETS = {
    "constriction": {"w": 0.7298, "phi1": 1.49618, "phi2": 1.49618, "vmax": 0.2},
    "paper": {"w": 0.1, "phi1": 2.0, "phi2": 2.0, "vmax": 1.0},
}


class ParticleSwarm(Optimizer):
    unit = "particle"

    def __init__(self, lower, upper, population: int = 20, w: float = 0.1, phi1: float = 2.0, phi2: float = 2.0,
                 seed: int = 0, vmax: float = 1.0):
        super().__init__(lower, upper, population)
        if population < 2:
            raise ValueError("population must be at least 2 particles")
        if not 0.0 < vmax <= 1.0:
            raise ValueError("vmax is a fraction of the box width in (0, 1]")
        self.w, self.phi1, self.phi2 = float(w), float(phi1), float(phi2)
        self.vmax = float(vmax)
        self.rng = np.random.default_rng(seed)
        self.x: np.ndarray | None = None
        self.v: np.ndarray | None = None
        self.pbest: np.ndarray | None = None
        self.pbest_f: np.ndarray | None = None
        self.last_f: np.ndarray | None = None
        self._asked = False

    def ask(self) -> np.ndarray:
        width = self.upper - self.lower
        vlim = self.vmax * width
        if self.x is None:
            self.x = self.lower + self.rng.random((self.population, self.dim)) * width
            self.v = (self.rng.random((self.population, self.dim)) - 0.5) * vlim
        else:
            g = self.pbest[int(np.argmax(self.pbest_f))]
            r1 = self.rng.random(self.x.shape)
            r2 = self.rng.random(self.x.shape)
            v = self.w * self.v + self.phi1 * r1 * (self.pbest - self.x) + self.phi2 * r2 * (g - self.x)  # Eq. 1
            v = np.clip(v, -vlim, vlim)
            x = self.x + v
            hit = (x < self.lower) | (x > self.upper)
            self.x = np.clip(x, self.lower, self.upper)
            self.v = np.where(hit, 0.0, v)
        self._asked = True
        return self.x.copy()

    def tell(self, fitness) -> None:
        f = self._fitness(fitness, self.population if self._asked else None)
        if self.pbest is None:
            self.pbest, self.pbest_f = self.x.copy(), f.copy()
        else:
            better = f > self.pbest_f
            self.pbest = np.where(better[:, None], self.x, self.pbest)
            self.pbest_f = np.where(better, f, self.pbest_f)
        self.last_f = f.copy()
        self._asked = False
        self.generation += 1

    @property
    def population_fitness(self) -> np.ndarray:
        """Fitness of the particles' current positions (the last generation told)."""
        return self.last_f

    @property
    def best(self) -> tuple[np.ndarray, float]:
        i = int(np.argmax(self.pbest_f))
        return self.pbest[i].copy(), float(self.pbest_f[i])

    def diagnostics(self) -> dict[str, float]:
        """How the swarm is spread: the share of coordinates on a wall and the mean per-
        coordinate spread relative to the box width (a uniform swarm has 1/sqrt(12) = 0.289)."""
        if self.x is None:
            return {"at_bounds": 0.0, "spread": 0.0}
        width = np.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        at = (self.x <= self.lower) | (self.x >= self.upper)
        return {"at_bounds": float(at.mean()), "spread": float(np.mean(self.x.std(axis=0) / width))}

    def state(self) -> dict:
        l = as_list
        return {"generation": self.generation, "x": l(self.x), "v": l(self.v), "pbest": l(self.pbest),
                "pbest_f": l(self.pbest_f), "last_f": l(self.last_f), "rng": self.rng.bit_generator.state}

    def restore(self, state: dict) -> None:
        a = as_array
        self.generation = int(state["generation"])
        self.x, self.v, self.pbest = a(state["x"]), a(state["v"]), a(state["pbest"])
        self.pbest_f, self.last_f = a(state["pbest_f"]), a(state["last_f"])
        self.rng.bit_generator.state = state["rng"]
        self._asked = False

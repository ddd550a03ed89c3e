"""Real-coded genetic algorithm (minimises) as an ask/tell optimiser with a JSON state.

Operators as in Deb's NSGA-II family (the ones pymoo ships for real variables): binary
tournament selection, simulated binary crossover (SBX, eta_c) and polynomial mutation
(eta_m, probability 1/D per gene), with the ``elite`` best kept unchanged. Written here
rather than taken from pymoo because pymoo's algorithm state (Population objects and
operator instances, its own generator handling) can only be checkpointed by pickling, not
as JSON, and a resumed job must continue bit for bit from a JSON checkpoint; this state is
a plain dict of lists plus numpy's generator state.
"""

from __future__ import annotations

import numpy as np

from app.optim.base import Optimizer, as_array, as_list


class GeneticAlgorithm(Optimizer):
    maximises = False  # the energy kind minimises its cost of transport

    def __init__(self, lower, upper, population: int = 40, crossover: float = 0.9, eta_c: float = 15.0,
                 eta_m: float = 20.0, elite: int = 2, seed: int = 0):
        super().__init__(lower, upper, population)
        if population < 4 or population % 2:
            raise ValueError("population must be even and at least 4")
        self.crossover, self.eta_c, self.eta_m = crossover, eta_c, eta_m
        self.elite = int(elite)
        self.rng = np.random.default_rng(seed)
        self.pop: np.ndarray | None = None
        self.fit: np.ndarray | None = None
        self._trial: np.ndarray | None = None

    def _tournament(self, n: int) -> np.ndarray:
        a = self.rng.integers(0, self.population, size=n)
        b = self.rng.integers(0, self.population, size=n)
        return np.where(self.fit[a] <= self.fit[b], a, b)

    def _sbx(self, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u = self.rng.random(p1.shape)
        beta = np.where(u <= 0.5, (2 * u) ** (1 / (self.eta_c + 1)), (1 / (2 * (1 - u))) ** (1 / (self.eta_c + 1)))
        do = (self.rng.random(p1.shape[0]) < self.crossover)[:, None] & (self.rng.random(p1.shape) < 0.5)
        c1 = 0.5 * ((1 + beta) * p1 + (1 - beta) * p2)
        c2 = 0.5 * ((1 - beta) * p1 + (1 + beta) * p2)
        return np.where(do, c1, p1), np.where(do, c2, p2)

    def _mutate(self, x: np.ndarray) -> np.ndarray:
        span = self.upper - self.lower
        u = self.rng.random(x.shape)
        delta = np.where(u < 0.5, (2 * u) ** (1 / (self.eta_m + 1)) - 1, 1 - (2 * (1 - u)) ** (1 / (self.eta_m + 1)))
        mask = self.rng.random(x.shape) < 1.0 / self.dim
        return np.where(mask, x + delta * span, x)

    def ask(self) -> np.ndarray:
        if self.pop is None:
            self._trial = self.lower + self.rng.random((self.population, self.dim)) * (self.upper - self.lower)
            return self._trial.copy()
        n = self.population - self.elite
        n_pairs = (n + 1) // 2
        p1 = self.pop[self._tournament(n_pairs)]
        p2 = self.pop[self._tournament(n_pairs)]
        c1, c2 = self._sbx(p1, p2)
        kids = np.concatenate([c1, c2])[:n]
        kids = np.clip(self._mutate(kids), self.lower, self.upper)
        order = np.argsort(self.fit, kind="stable")[: self.elite]
        self._trial = np.concatenate([self.pop[order], kids])
        return self._trial.copy()

    def tell(self, fitness) -> None:
        fitness = self._fitness(fitness, None if self._trial is None else self._trial.shape[0])
        self.pop, self.fit = self._trial, fitness
        self._trial = None
        self.generation += 1

    @property
    def best(self) -> tuple[np.ndarray, float]:
        i = int(np.argmin(self.fit))
        return self.pop[i].copy(), float(self.fit[i])

    def state(self) -> dict:
        return {"generation": self.generation,
                "pop": as_list(self.pop),
                "fit": as_list(self.fit),
                "rng": self.rng.bit_generator.state}

    def restore(self, state: dict) -> None:
        self.generation = int(state["generation"])
        self.pop, self.fit = as_array(state["pop"]), as_array(state["fit"])
        self.rng.bit_generator.state = state["rng"]
        self._trial = None

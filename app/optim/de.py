"""Differential evolution exactly as paper 000, Eq. 7-10, as an ask/tell optimiser.

current-to-best/1 mutation (Eq. 7), binomial crossover without a forced index (Eq. 8),
clipping to the bounds (Eq. 9), greedy selection that keeps ties for the trial (Eq. 10).
Maximises. The state is a plain dict of arrays and the generator's state, so a
checkpoint restores bit-identical continuation.
"""

from __future__ import annotations

import numpy as np

from app.optim.base import Optimizer, as_array, as_list


class DifferentialEvolution(Optimizer):
    def __init__(self, lower, upper, population: int = 30, cr: float = 0.6, f: float = 0.5, seed: int = 0):
        super().__init__(lower, upper, population)
        if population < 4:
            raise ValueError("population must be at least 4 (current-to-best/1 needs two other members)")
        self.cr, self.f = float(cr), float(f)
        self.rng = np.random.default_rng(seed)
        self.pop: np.ndarray | None = None
        self.fit: np.ndarray | None = None
        self._trial: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        if self.pop is None:
            # Step 1: uniform initial population inside the bounds.
            self._trial = self.lower + self.rng.random((self.population, self.dim)) * (self.upper - self.lower)
            return self._trial.copy()
        P, D = self.pop.shape
        best = self.pop[np.argmax(self.fit)]
        # r1 != r2, both != k: draw from the P-1 others, then the P-2 others.
        k = np.arange(P)
        r1 = (k + 1 + self.rng.integers(0, P - 1, size=P)) % P
        r2 = self.rng.integers(0, P - 2, size=P)
        lo, hi = np.minimum(k, r1), np.maximum(k, r1)  # skip both, smaller first
        r2 = np.where(r2 >= lo, r2 + 1, r2)
        r2 = np.where(r2 >= hi, r2 + 1, r2)
        v = self.pop + self.f * (best - self.pop) + self.f * (self.pop[r1] - self.pop[r2])  # Eq. 7
        cross = self.rng.random((P, D)) <= self.cr  # Eq. 8
        u = np.where(cross, v, self.pop)
        self._trial = np.clip(u, self.lower, self.upper)  # Eq. 9
        return self._trial.copy()

    def tell(self, fitness) -> None:
        fitness = self._fitness(fitness, None if self._trial is None else self._trial.shape[0])
        if self.pop is None:
            self.pop, self.fit = self._trial, fitness
        else:
            keep = fitness >= self.fit  # Eq. 10: the trial wins ties
            self.pop = np.where(keep[:, None], self._trial, self.pop)
            self.fit = np.where(keep, fitness, self.fit)
        self._trial = None
        self.generation += 1

    def selection_thresholds(self) -> np.ndarray | None:
        """A trial replaces its parent only if its fitness is at least the parent's (Eq. 10);
        the initial population has no parents."""
        return None if self.pop is None or self._trial is None else self.fit.copy()

    @property
    def population_fitness(self) -> np.ndarray:
        """Fitness of the current population (after selection)."""
        return self.fit

    @property
    def best(self) -> tuple[np.ndarray, float]:
        i = int(np.argmax(self.fit))
        return self.pop[i].copy(), float(self.fit[i])

    def state(self) -> dict:
        return {
            "generation": self.generation,
            "pop": as_list(self.pop),
            "fit": as_list(self.fit),
            "rng": self.rng.bit_generator.state,
        }

    def restore(self, state: dict) -> None:
        self.generation = int(state["generation"])
        self.pop, self.fit = as_array(state["pop"]), as_array(state["fit"])
        self.rng.bit_generator.state = state["rng"]
        self._trial = None

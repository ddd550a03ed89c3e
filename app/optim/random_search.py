"""Random search: every generation a fresh batch of points drawn uniformly in the box.

The control every population search is compared with at equal budget (same evaluator,
same number of evaluations). Same ask/tell interface as the other optimisers; maximises;
the state (best so far, generator state) is a JSON-able dict.
"""

from __future__ import annotations

import numpy as np


class RandomSearch:
    def __init__(self, lower, upper, population: int = 20, seed: int = 0):
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        if self.lower.shape != self.upper.shape or np.any(self.lower > self.upper):
            raise ValueError("lower and upper bounds must have the same shape with lower <= upper")
        if population < 1:
            raise ValueError("population must be at least 1")
        self.population = int(population)
        self.rng = np.random.default_rng(seed)
        self.generation = 0
        self.x: np.ndarray | None = None
        self.best_x: np.ndarray | None = None
        self.best_f = -np.inf
        self.last_f: np.ndarray | None = None
        self._asked = False

    @property
    def dim(self) -> int:
        return self.lower.size

    def ask(self) -> np.ndarray:
        self.x = self.lower + self.rng.random((self.population, self.dim)) * (self.upper - self.lower)
        self._asked = True
        return self.x.copy()

    def tell(self, fitness) -> None:
        f = np.asarray(fitness, dtype=float)
        if not self._asked or f.shape != (self.population,):
            raise ValueError("tell() needs one fitness per point of the last ask()")
        i = int(np.argmax(f))
        if f[i] > self.best_f:
            self.best_x, self.best_f = self.x[i].copy(), float(f[i])
        self.last_f = f.copy()
        self._asked = False
        self.generation += 1

    @property
    def population_fitness(self) -> np.ndarray:
        return self.last_f

    @property
    def best(self) -> tuple[np.ndarray, float]:
        if self.best_x is None:
            raise ValueError("nothing told yet")
        return self.best_x.copy(), self.best_f

    def state(self) -> dict:
        return {"generation": self.generation, "best_x": None if self.best_x is None else self.best_x.tolist(),
                "best_f": self.best_f if self.best_x is not None else None,
                "last_f": None if self.last_f is None else self.last_f.tolist(), "rng": self.rng.bit_generator.state}

    def restore(self, state: dict) -> None:
        self.generation = int(state["generation"])
        self.best_x = None if state["best_x"] is None else np.asarray(state["best_x"], dtype=float)
        self.best_f = -np.inf if state["best_f"] is None else float(state["best_f"])
        self.last_f = None if state["last_f"] is None else np.asarray(state["last_f"], dtype=float)
        self.rng.bit_generator.state = state["rng"]
        self._asked = False

"""Random search: every generation a fresh batch of points drawn uniformly in the box.

The control every population search is compared with at equal budget (same evaluator,
same number of evaluations). Same ask/tell interface as the other optimisers; maximises;
the state (best so far, generator state) is a JSON-able dict.
"""

from __future__ import annotations

import numpy as np

from app.optim.base import Optimizer, as_array, as_list


class RandomSearch(Optimizer):
    unit = "point"

    def __init__(self, lower, upper, population: int = 20, seed: int = 0):
        super().__init__(lower, upper, population)
        if population < 1:
            raise ValueError("population must be at least 1")
        self.rng = np.random.default_rng(seed)
        self.x: np.ndarray | None = None
        self.best_x: np.ndarray | None = None
        self.best_f = -np.inf
        self.last_f: np.ndarray | None = None
        self._asked = False

    def ask(self) -> np.ndarray:
        self.x = self.lower + self.rng.random((self.population, self.dim)) * (self.upper - self.lower)
        self._asked = True
        return self.x.copy()

    def tell(self, fitness) -> None:
        f = self._fitness(fitness, self.population if self._asked else None)
        i = int(np.argmax(f))
        if f[i] > self.best_f:
            self.best_x, self.best_f = self.x[i].copy(), float(f[i])
        self.last_f = f.copy()
        self._asked = False
        self.generation += 1

    def selection_thresholds(self) -> np.ndarray | None:
        """Only a candidate above the best so far changes what this search keeps (its draws
        never depend on fitness): every candidate's threshold is that best; before the
        first generation is told there is none."""
        if not self._asked or self.best_x is None:
            return None
        return np.full(self.population, self.best_f)

    @property
    def population_fitness(self) -> np.ndarray:
        return self.last_f

    @property
    def best(self) -> tuple[np.ndarray, float]:
        if self.best_x is None:
            raise ValueError("nothing told yet")
        return self.best_x.copy(), self.best_f

    def state(self) -> dict:
        return {"generation": self.generation, "best_x": as_list(self.best_x),
                "best_f": self.best_f if self.best_x is not None else None,
                "last_f": as_list(self.last_f), "rng": self.rng.bit_generator.state}

    def restore(self, state: dict) -> None:
        self.generation = int(state["generation"])
        self.best_x = as_array(state["best_x"])
        self.best_f = -np.inf if state["best_f"] is None else float(state["best_f"])
        self.last_f = as_array(state["last_f"])
        self.rng.bit_generator.state = state["rng"]
        self._asked = False

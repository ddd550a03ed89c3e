"""CMA-ES through the ``cma`` package, behind the same ask/tell interface as DE.

Searches the unit cube (bounds scaled to [0, 1] per coordinate, so one step size suits
every parameter) with cma's own boundary handling; maximises by telling cma -F.
"""

from __future__ import annotations

import base64
import pickle

import cma
import numpy as np


class CMAES:
    def __init__(self, lower, upper, population: int = 30, seed: int = 0, sigma0: float = 0.25):
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        if population < 4:
            raise ValueError("population must be at least 4")
        self.population = int(population)
        self.generation = 0
        self._es = cma.CMAEvolutionStrategy(
            np.full(self.lower.size, 0.5), sigma0,
            {"bounds": [0.0, 1.0], "popsize": self.population, "seed": int(seed) + 1,  # cma: seed 0 = random
             "verbose": -9, "verb_log": 0, "verb_disp": 0, "tolx": 0, "tolfun": 0, "tolfunhist": 0,
             "tolstagnation": 10**9, "maxiter": 10**9},
        )
        self._asked: list[np.ndarray] | None = None
        self._best_x: np.ndarray | None = None
        self._best_f = -np.inf
        self.population_fitness: np.ndarray | None = None  # of the last generation told

    @property
    def dim(self) -> int:
        return self.lower.size

    def _scale(self, z: np.ndarray) -> np.ndarray:
        return self.lower + np.clip(z, 0.0, 1.0) * (self.upper - self.lower)

    def ask(self) -> np.ndarray:
        self._asked = self._es.ask()
        return self._scale(np.asarray(self._asked))

    def tell(self, fitness) -> None:
        fitness = np.asarray(fitness, dtype=float)
        if self._asked is None or fitness.shape != (len(self._asked),):
            raise ValueError("tell() needs one fitness per candidate of the last ask()")
        self._es.tell(self._asked, (-fitness).tolist())
        self.population_fitness = fitness
        i = int(np.argmax(fitness))
        if fitness[i] > self._best_f:  # CMA's mean moves on; the best ever seen is kept
            self._best_x, self._best_f = self._scale(np.asarray(self._asked[i])), float(fitness[i])
        self._asked = None
        self.generation += 1

    @property
    def best(self) -> tuple[np.ndarray, float]:
        return self._best_x.copy(), self._best_f

    def state(self) -> dict:
        blob = pickle.dumps((self._es, self._best_x, self._best_f, self.generation, self.population_fitness))
        return {"generation": self.generation, "cma": base64.b64encode(blob).decode("ascii")}

    def restore(self, state: dict) -> None:
        self._es, self._best_x, self._best_f, self.generation, self.population_fitness = pickle.loads(base64.b64decode(state["cma"]))
        self._asked = None

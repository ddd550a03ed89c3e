"""CMA-ES through the ``cma`` package, behind the same ask/tell interface as DE.

Searches the unit cube (bounds scaled to [0, 1] per coordinate, so one step size suits
every parameter) with cma's own boundary handling; maximises by telling cma -F.

The state is JSON, not a pickle of cma's object (a worker must never unpickle what it
reads from the database): the fitness values told so far. ``restore`` rebuilds the
strategy from its seed and replays ask / tell with them, which is deterministic (cma
draws from NumPy's global generator, seeded by the strategy's constructor) and cheap next
to the evaluations it stands for.
"""

from __future__ import annotations

import cma
import numpy as np

from app.optim.base import Optimizer, as_array, as_list


class CMAES(Optimizer):
    def __init__(self, lower, upper, population: int = 30, seed: int = 0, sigma0: float = 0.25):
        super().__init__(lower, upper, population)
        if population < 4:
            raise ValueError("population must be at least 4")
        self.seed, self.sigma0 = int(seed), float(sigma0)
        self._new_strategy()
        self._asked: list[np.ndarray] | None = None
        self._told: list[list[float]] = []
        self._best_x: np.ndarray | None = None
        self._best_f = -np.inf
        self.population_fitness: np.ndarray | None = None  # of the last generation told

    def _new_strategy(self) -> None:
        self.generation = 0
        self._es = cma.CMAEvolutionStrategy(
            np.full(self.lower.size, 0.5), self.sigma0,
            {"bounds": [0.0, 1.0], "popsize": self.population, "seed": self.seed + 1,  # cma: seed 0 = random
             "verbose": -9, "verb_log": 0, "verb_disp": 0, "tolx": 0, "tolfun": 0, "tolfunhist": 0,
             "tolstagnation": 10**9, "maxiter": 10**9},
        )

    def _scale(self, z: np.ndarray) -> np.ndarray:
        return self.lower + np.clip(z, 0.0, 1.0) * (self.upper - self.lower)

    def ask(self) -> np.ndarray:
        self._asked = self._es.ask()
        return self._scale(np.asarray(self._asked))

    def tell(self, fitness, provisional: bool = False) -> None:
        """``provisional``: the values of a cheaper stand-in (a shorter walk) that only rank
        the candidates, which is all CMA-ES's update uses; they do not count for the best."""
        fitness = self._fitness(fitness, None if self._asked is None else len(self._asked))
        self._es.tell(self._asked, (-fitness).tolist())
        self._told.append(fitness.tolist())
        self.population_fitness = fitness
        i = int(np.argmax(fitness))
        if not provisional and fitness[i] > self._best_f:  # CMA's mean moves on; the best ever seen is kept
            self._best_x, self._best_f = self._scale(np.asarray(self._asked[i])), float(fitness[i])
        self._asked = None
        self.generation += 1

    @property
    def best(self) -> tuple[np.ndarray, float]:
        return self._best_x.copy(), self._best_f

    def state(self) -> dict:
        return {"generation": self.generation, "seed": self.seed, "sigma0": self.sigma0, "told": self._told,
                "best_x": as_list(self._best_x),
                "best_f": None if self._best_x is None else self._best_f}

    def restore(self, state: dict) -> None:
        self.seed, self.sigma0 = int(state["seed"]), float(state["sigma0"])
        self._new_strategy()
        self._told = []
        for f in state["told"]:
            self._asked = self._es.ask()
            self._es.tell(self._asked, (-np.asarray(f, dtype=float)).tolist())
            self._told.append(list(f))
            self.generation += 1
        self._asked = None
        self.population_fitness = np.asarray(self._told[-1]) if self._told else None
        self._best_x = as_array(state["best_x"])
        self._best_f = -np.inf if state["best_f"] is None else float(state["best_f"])
        if self.generation != int(state["generation"]):
            raise ValueError("CMA-ES state: generation does not match the fitness values told")

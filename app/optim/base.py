"""The one optimiser interface: ask / tell over a box, a JSON-able state.

Every optimiser in app/optim subclasses ``Optimizer``: ``ask()`` returns the next
population (an array of shape (population, dim), every row inside the bounds),
``tell(fitness)`` takes one value per row of the last ask, ``best`` is the best candidate
seen with its fitness, ``state()`` is a dict of plain numbers and lists (a checkpoint in
the database: never a pickle) and ``restore(state)`` continues bit-identically from it.

The bounds are checked here, once, for every optimiser. ``maximises`` says which way the
optimiser looks: all maximise but the GA, which minimises (the energy kind's cost of
transport). ``generation`` counts the tells so far (app/jobs/loop.py runs until it
reaches the budget).
"""

from __future__ import annotations

import abc
from typing import Any, ClassVar

import numpy as np


def check_bounds(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """The box as float arrays; a ValueError unless both have one shape and lower <= upper."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    if lower.shape != upper.shape or np.any(lower > upper):
        raise ValueError("lower and upper bounds must have the same shape with lower <= upper")
    return lower, upper


def as_list(a: np.ndarray | None) -> list | None:
    """An array (or None) for a JSON state."""
    return None if a is None else a.tolist()


def as_array(v: Any) -> np.ndarray | None:
    """A state's list (or None) back to a float array."""
    return None if v is None else np.asarray(v, dtype=float)


class Optimizer(abc.ABC):
    """A population optimiser over the box [lower, upper] with an ask/tell loop."""

    maximises: ClassVar[bool] = True
    unit: ClassVar[str] = "candidate"  # what one row of ask() is called in error messages

    def __init__(self, lower, upper, population: int):
        self.lower, self.upper = check_bounds(lower, upper)
        self.population = int(population)
        self.generation = 0

    @property
    def dim(self) -> int:
        return self.lower.size

    @abc.abstractmethod
    def ask(self) -> np.ndarray:
        """The next population to evaluate, shape (population, dim), inside the bounds."""

    @abc.abstractmethod
    def tell(self, fitness) -> None:
        """One fitness per row of the last ask(); advances ``generation`` by one."""

    @property
    @abc.abstractmethod
    def best(self) -> tuple[np.ndarray, float]:
        """The best candidate so far and its fitness (the largest, or smallest when
        ``maximises`` is False)."""

    @abc.abstractmethod
    def state(self) -> dict:
        """Everything needed to continue: plain numbers, lists and dicts (JSON)."""

    @abc.abstractmethod
    def restore(self, state: dict) -> None:
        """Continue from ``state()``: the same asks as the run that wrote it."""

    def selection_thresholds(self) -> np.ndarray | None:
        """For the population last asked: the fitness each candidate must reach to change
        what the optimiser does next (DE: its parent's, Eq. 10), or None when every value
        matters (rank-based and swarm optimisers). An evaluator may stop evaluating a
        candidate once it provably cannot reach its threshold and tell any value below it."""
        return None

    def diagnostics(self) -> dict[str, float]:
        """Numbers about the search's own state for a log line (e.g. PSO's spread); none by default."""
        return {}

    def _fitness(self, fitness, asked: int | None) -> np.ndarray:
        """The told values as floats, checked against the last ask's size (None: nothing asked)."""
        fitness = np.asarray(fitness, dtype=float)
        if asked is None or fitness.shape != (asked,):
            raise ValueError(f"tell() needs one fitness per {self.unit} of the last ask()")
        return fitness

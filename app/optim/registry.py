"""Optimisers by name: every one is ask/tell, maximises, and checkpoints as a dict."""

from __future__ import annotations

from app.optim.cmaes import CMAES
from app.optim.de import DifferentialEvolution

OPTIMIZERS = ("de", "cmaes")


def make_optimizer(name: str, lower, upper, population: int, seed: int, cr: float = 0.6, f: float = 0.5):
    if name == "de":
        return DifferentialEvolution(lower, upper, population=population, cr=cr, f=f, seed=seed)
    if name == "cmaes":
        return CMAES(lower, upper, population=population, seed=seed)
    raise ValueError(f"unknown optimizer {name!r}; known: {OPTIMIZERS}")

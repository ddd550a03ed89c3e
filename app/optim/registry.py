"""Optimisers by name: every one is ask/tell, maximises, and checkpoints as a dict."""

from __future__ import annotations

from app.optim.de import DifferentialEvolution
from app.optim.pso import ParticleSwarm
from app.optim.random_search import RandomSearch

OPTIMIZERS = ("de", "cmaes", "pso", "random")


def make_optimizer(name: str, lower, upper, population: int, seed: int, cr: float = 0.6, f: float = 0.5,
                   w: float = 0.1, phi1: float = 2.0, phi2: float = 2.0, vmax: float = 1.0):
    if name == "de":
        return DifferentialEvolution(lower, upper, population=population, cr=cr, f=f, seed=seed)
    if name == "cmaes":
        from app.optim.cmaes import CMAES  # imports cma (and matplotlib): ~2.5 s, so only when asked

        return CMAES(lower, upper, population=population, seed=seed)
    if name == "pso":
        return ParticleSwarm(lower, upper, population=population, w=w, phi1=phi1, phi2=phi2, seed=seed, vmax=vmax)
    if name == "random":
        return RandomSearch(lower, upper, population=population, seed=seed)
    raise ValueError(f"unknown optimizer {name!r}; known: {OPTIMIZERS}")

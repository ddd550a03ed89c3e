"""Optimisers by name: every one is an ``Optimizer`` (app/optim/base.py: ask/tell over a
box, a JSON-able state). All maximise but ``ga``, which minimises (``maximises`` says it)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from app.optim.base import Optimizer
from app.optim.de import DifferentialEvolution
from app.optim.ga import GeneticAlgorithm
from app.optim.pso import ParticleSwarm
from app.optim.random_search import RandomSearch


def _cmaes() -> type[Optimizer]:
    from app.optim.cmaes import CMAES  # imports cma (and matplotlib): ~2.5 s, so only when asked

    return CMAES


# name -> (the class, loaded when first asked for; the settings of its own it takes)
_TABLE: dict[str, tuple[Callable[[], type[Optimizer]], tuple[str, ...]]] = {
    "de": (lambda: DifferentialEvolution, ("cr", "f")),
    "cmaes": (_cmaes, ("sigma0",)),
    "pso": (lambda: ParticleSwarm, ("w", "phi1", "phi2", "vmax")),
    "random": (lambda: RandomSearch, ()),
    "ga": (lambda: GeneticAlgorithm, ("crossover", "eta_c", "eta_m", "elite")),
}
OPTIMIZERS = tuple(_TABLE)
SETTINGS = frozenset(p for _, params in _TABLE.values() for p in params)
MINIMISERS = frozenset({"ga"})  # each class's ``maximises`` (tests/optim/test_interface.py checks it)
MAXIMISERS = tuple(n for n in OPTIMIZERS if n not in MINIMISERS)


def check_name(name: str, maximise: bool = True) -> str:
    """``name`` if it is a registered optimiser that looks the way a kind's search looks
    (maximises, or minimises); else a ValueError that lists the ones that fit."""
    fits = [n for n in OPTIMIZERS if (n not in MINIMISERS) == maximise]
    if name not in fits:
        why = "unknown" if name not in _TABLE else ("it minimises" if maximise else "it maximises")
        raise ValueError(f"optimizer {name!r}: {why}; allowed: {', '.join(fits)}")
    return name


def make_optimizer(name: str, lower, upper, population: int, seed, **settings: Any) -> Optimizer:
    """The optimiser ``name`` over [lower, upper]. ``settings`` may hold any optimiser's own
    settings (DE: cr, f; CMA-ES: sigma0; PSO: w, phi1, phi2, vmax; GA: crossover, eta_c,
    eta_m, elite): each optimiser takes its own and ignores the others', so one search
    section can be handed to whichever optimiser it names; those left out keep the class's
    defaults. A setting no optimiser has is a TypeError."""
    if name not in _TABLE:
        raise ValueError(f"unknown optimizer {name!r}; known: {OPTIMIZERS}")
    unknown = sorted(set(settings) - SETTINGS)
    if unknown:
        raise TypeError(f"no optimizer has the setting(s) {unknown}; known: {sorted(SETTINGS)}")
    load, own = _TABLE[name]
    return load()(lower, upper, population=population, seed=seed, **{k: v for k, v in settings.items() if k in own})

"""`gaitmend reproduce adapt`'s options and registration, light to import (the CLI lists it at
start): the work is app/adapt/reproduce/evaluation.py's, imported when the command runs."""

from __future__ import annotations

from collections.abc import Callable

from app.adapt.reproduce.params import AntParams, Params
from app.jobs.base import Experiment


def _run(p: Params, log: Callable[[str], None]) -> str:
    from app.adapt.reproduce.evaluation import reproduce

    return reproduce(p, log)


EXPERIMENT = Experiment(
    "adapt", "ITE as published against gaitmend's multi-prior adaptation (and ablations, a random pick) on random "
    "simulated realities of the hexapod, reality by reality into docs/adapt_evaluation.json (those there are kept)",
    Params, _run, ())

ANT_EXPERIMENT = Experiment(
    "adapt-ant", "the same evaluation on the Gymnasium ant uploaded as a user's robot (its maps, realities of five "
    "damage types of the one vocabulary by its leg map's names, held-out worlds), reality by reality into "
    "docs/adapt_evaluation_ant.json (those there are kept)", AntParams, _run, ())

"""What reproduces a paper: the research hooks of the kind contract (``ReproducesPaper``:
``experiments`` and ``bench``) and their records (``Experiment``, ``BenchEntry``). A kind
keeps what they run in its ``reproduce/`` package, reached only through these hooks, so no
job ever loads it (tests/test_layers.py). app/jobs/base.py composes this part into ``Kind``
and re-exports every name."""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel


@dataclasses.dataclass(frozen=True)
class Experiment:
    """A paper reproduction: ``gaitmend reproduce <kind>`` (the first experiment of a kind)
    or ``gaitmend reproduce <kind>-<name>``. ``Params`` (a pydantic model of scalar fields
    with defaults and descriptions) become the command's options; ``run(params, log)``
    returns the markdown it reports (and writes where ``params`` say)."""

    name: str
    help: str
    Params: type[BaseModel]
    run: Callable[[Any, Callable[[str], None]], str]
    sections: tuple[Any, ...] = ()
    """The generated sections of the docs this experiment's committed JSON renders
    (app/jobs/reporting.py ``Section``; ``gaitmend docs`` rewrites them)."""


@dataclasses.dataclass(frozen=True)
class BenchEntry:
    """One figure group of ``gaitmend bench``: ``run(quick, log) -> {name: number | dict}``."""

    name: str
    help: str
    run: Callable[[bool, Callable[[str], None]], dict[str, Any]]


class ReproducesPaper(abc.ABC):
    """What reproduces the kind's paper and measures its speed: ``experiments`` (what
    `gaitmend reproduce <kind>[-<name>]` runs) and ``bench`` (the figure groups of
    `gaitmend bench`). Both default to none.

    Invariants:
        - Calling a hook only lists records; nothing runs until a record's ``run`` is
          called. The first experiment is the kind's ``gaitmend reproduce <kind>``; names
          are unique within the kind.
        - An experiment's numbers depend only on its ``Params`` (seeds included): the JSON
          it writes with ``--write-docs`` is the same on every run, and the docs' generated
          sections (``Experiment.sections``) are rendered from that committed JSON.
        - The job's runtime never imports what these hooks run (the kind's ``reproduce/``).

    Ownership:
        - The kind owns its experiments, their JSON and the doc sections they render; the
          CLI (`gaitmend reproduce`, `gaitmend bench`, `gaitmend docs`) owns the options
          built from ``Params`` and where the log goes.

    Raises:
        - The hooks themselves raise nothing; an experiment's ``run`` raises what its work
          raises (a ``SpecError`` for a spec it builds that must not run).
    """

    # -- reproduction, benchmarks, dashboard ----------------------------------------------
    def experiments(self) -> list[Experiment]:
        """The paper reproductions, the first one the kind's ``gaitmend reproduce <kind>``;
        default none."""
        return []

    def bench(self) -> list[BenchEntry]:
        """The figure groups ``gaitmend bench`` measures for this kind; default none."""
        return []

"""The kind contract: ``Kind``, what the CLI, API, worker, bundle, replay, bench and dashboard
may ask of a job kind, made of three parts, each documented with its invariants, who owns
what and what it raises:

- what runs a job (``RunsJob``, app/jobs/kind_run.py),
- what presents a result (``PresentsResult``, app/jobs/kind_present.py),
- what reproduces a paper (``ReproducesPaper``, app/jobs/kind_reproduce.py);

and here, the kind's identity, ``PackageKind`` (a kind laid out as a package, with its
``Deferred`` members) and ``check_kind`` (the contract checked at registration).

What every kind shares besides the contract lives beside it and is re-exported here, so
``from app.jobs.base import X`` reaches all of it: the spec base and its errors
(app/jobs/spec_base.py), the run context (app/jobs/run_context.py), the result and its JSON
(app/jobs/job_result.py), the presentation and reproduction records. docs/architecture.md
describes the layers and the contract."""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import inspect
import json
import sys
from collections.abc import Callable
from importlib import resources
from typing import Any, ClassVar

from app.jobs.job_result import JobResult, dumps, to_jsonable
from app.jobs.kind_present import (COMMON_FILES, HeadlineRow, PresentsResult, ReplayTrack, Table, form_fields,
                                   headline_row, table)
from app.jobs.kind_reproduce import BenchEntry, Experiment, ReproducesPaper
from app.jobs.kind_run import RunsJob
from app.jobs.run_context import Cancelled, MemoryContext, RunContext
from app.jobs.spec_base import STRICT, SpecBase, SpecError, StrictModel

__all__ = [
    "COMMON_FILES", "STRICT", "BenchEntry", "Cancelled", "Deferred", "Experiment", "HeadlineRow", "JobResult", "Kind",
    "MemoryContext", "PackageKind", "PresentsResult", "ReplayTrack", "ReproducesPaper", "RunContext", "RunsJob",
    "SpecBase", "SpecError", "StrictModel", "Table", "check_kind", "contract_members", "dumps", "form_fields",
    "headline_row", "table", "to_jsonable",
]


class Kind(RunsJob, PresentsResult, ReproducesPaper):
    """A job kind: one package ``app/jobs/<name>/`` and one registry line.

    Everything outside the package (CLI, API, store, worker, bundle, replay, bench,
    dashboard) reaches a kind only through these attributes and methods, never by its
    name. ``Kind`` is its identity (below) and the three parts of the contract it
    inherits, which declare every other member a kind may provide, each with its default:
    what runs a job (``RunsJob``), what presents a result (``PresentsResult``) and what
    reproduces a paper (``ReproducesPaper``). A kind sets the required attributes
    (``REQUIRED``) and implements ``run``, ``headline``, ``summary_tables`` and
    ``figures``; the rest have defaults that fit most kinds. A kind that sets a name the
    contract does not declare (a misspelt optional member would otherwise be ignored in
    silence) is refused at registration (``check_kind``, called by app/jobs/registry.py).

    Counting convention (every population search, see app/jobs/loop.py): generation 0 is
    the initial population; a search of G generations evaluates P x (G + 1) candidates.
    """

    name: ClassVar[str]
    """The spec's ``kind`` (required)."""
    title: ClassVar[str]
    """A short human title (required)."""
    paper: ClassVar[str]
    """The citation of the paper it implements (required)."""
    Spec: ClassVar[type[SpecBase]]
    """The kind's spec model, on ``SpecBase`` (required)."""
    robots: ClassVar[dict[str, str]]
    """Robot name -> description, for /api/robots (required)."""

    REQUIRED: ClassVar[tuple[str, ...]] = ("name", "title", "paper", "Spec", "robots")

    def __repr__(self) -> str:
        return f"<kind {self.name}>"


class Deferred:
    """A member found in one of the kind package's own modules when first used, for modules
    slow to import (run, experiments, bench): ``Deferred(".run", "run")`` calls the ``run``
    function of the package's ``run`` module; with ``value=True`` the member returns the
    attribute itself (``Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)``). Registration
    checks that the module exists, without importing it, so a misspelt module fails there."""

    def __init__(self, module: str, attr: str, value: bool = False):
        self.module, self.attr, self.value = module, attr, value
        self.package = ""

    def __set_name__(self, owner: type, name: str) -> None:
        # a relative module is relative to the package of the class that names it
        module = sys.modules[owner.__module__]
        self.package = module.__name__ if hasattr(module, "__path__") else module.__name__.rpartition(".")[0]

    def __get__(self, kind: Any, owner: type) -> Any:
        if kind is None:
            return self
        package = self.package

        def member(*args: Any, **kw: Any) -> Any:
            found = getattr(importlib.import_module(self.module, package), self.attr)
            return found if self.value else found(*args, **kw)

        member.__name__ = self.attr
        return member

    def error(self, where: str, name: str) -> str | None:
        """Why this member cannot be found (None when its module exists)."""
        try:
            found = importlib.util.find_spec(self.module, self.package) is not None
        except ModuleNotFoundError:
            found = False
        return None if found else f"{where}.{name}: no module {self.module!r} (from {self.package})"


class PackageKind(Kind):
    """A kind laid out as ``app/jobs/<name>/`` (docs/architecture.md). Its ``__init__``
    subclasses this and supplies each member explicitly: values as class attributes, the
    functions of its modules as ``staticmethod(present.headline)`` (modules imported with
    the package: present, views), and members whose module is slow to import (run,
    experiments, bench) as ``Deferred`` members, imported when first called. A member it does not
    supply keeps the ``Kind`` default; one the contract does not declare is refused at
    registration.

    ``builtin_studies`` reads the package's ``studies/<name>.json`` (package data, so they
    ship in the wheel): those named in ``study_order`` first, in that order (the paper's
    table first), then the rest sorted by name."""

    study_order: ClassVar[tuple[str, ...]] = ()
    """Built-in studies listed first, in this order (the paper's table first)."""

    def builtin_studies(self) -> dict[str, dict[str, Any]]:
        module = sys.modules[type(self).__module__]
        package = module.__name__ if hasattr(module, "__path__") else module.__name__.rpartition(".")[0]
        folder = resources.files(package).joinpath("studies")
        files = {f.name[:-len(".json")]: f for f in folder.iterdir()
                 if f.name.endswith(".json") and f.is_file()} if folder.is_dir() else {}
        missing = [n for n in self.study_order if n not in files]
        if missing:
            raise ValueError(f"{type(self).__name__}.study_order names no file {package}/studies/<name>.json: {missing}")
        names = [*self.study_order, *sorted(n for n in files if n not in self.study_order)]
        return {n: json.loads(files[n].read_text()) for n in names}


# -- checking a kind against the contract ------------------------------------------------------

# the classes that declare the contract's members
_DECLARING = (RunsJob, PresentsResult, ReproducesPaper, Kind, PackageKind)


def contract_members(kind_cls: type[Kind]) -> dict[str, Any]:
    """{name: its declaration} of every member ``kind_cls`` may set: those Kind and its
    three parts declare, and PackageKind's too for a PackageKind."""
    out: dict[str, Any] = {}
    for c in reversed(kind_cls.__mro__):
        if c in _DECLARING:
            names = [*c.__dict__.get("__annotations__", {}), *vars(c)]
            out.update({n: c.__dict__.get(n) for n in names if not n.startswith("_") and n != "REQUIRED"})
    return out


def _supplied(kind: Kind) -> list[tuple[str, str, Any, bool]]:
    """(where, name, value, on a class) of every public name the kind's own classes and
    instance set."""
    out = []
    for c in type(kind).__mro__:
        if c in _DECLARING or c is object or not issubclass(c, Kind):
            continue
        names = [*c.__dict__.get("__annotations__", {}), *vars(c)]
        out += [(c.__qualname__, n, c.__dict__.get(n), True) for n in dict.fromkeys(names) if not n.startswith("_")]
    out += [(f"{type(kind).__qualname__}()", n, v, False) for n, v in vars(kind).items() if not n.startswith("_")]
    return out


def _signature_error(where: str, name: str, declared: Callable, value: Any, bound: bool) -> str | None:
    """Why ``value`` cannot stand in for the method ``declared`` (None when it can).
    ``bound``: a function set on the class (it gets the kind as its first argument)."""
    if isinstance(value, property):
        return None
    if isinstance(value, (staticmethod, classmethod)):
        fn, first = value.__func__, (["cls"] if isinstance(value, classmethod) else [])
    elif callable(value):
        fn, first = value, (["self"] if bound and inspect.isfunction(value) else [])
    else:
        return f"{where}.{name} must be callable like Kind.{name}, not a {type(value).__name__}"
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):  # no signature to read (a builtin): trusted
        return None
    args = [*first, *list(inspect.signature(declared).parameters)[1:]]
    try:
        sig.bind(*args)
    except TypeError:
        return (f"{where}.{name}{sig} cannot be called as Kind.{name}{inspect.signature(declared)} "
                "(a module's function is given as staticmethod(function))")
    return None


def check_kind(kind: Kind) -> None:
    """Refuse (TypeError naming the member) a kind that sets a name the contract does not
    declare, gives a method's place something that cannot be called like it, or lacks a
    required attribute. app/jobs/registry.py calls it for every kind it registers."""
    members = contract_members(type(kind))
    for where, name, value, on_class in _supplied(kind):
        if name not in members:
            close = difflib.get_close_matches(name, members, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise TypeError(f"{where}.{name} is not a member of the kind contract (app/jobs/base.py Kind){hint}")
        declared = members[name]
        if isinstance(value, Deferred):
            err = value.error(where, name)
            if err:
                raise TypeError(err)
        elif inspect.isfunction(declared):
            err = _signature_error(where, name, declared, value, bound=on_class)
            if err:
                raise TypeError(err)
    missing = [n for n in Kind.REQUIRED if not hasattr(kind, n)]
    if missing:
        raise TypeError(f"{type(kind).__qualname__} does not set the required member(s) {missing}")

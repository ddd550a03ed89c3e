"""What every job kind shares, and the kind contract: spec errors, the strict spec base,
the run context, the result, the presentation records, and ``Kind`` (what the CLI, API,
worker, bundle, replay, bench and dashboard may ask of a kind). docs/architecture.md
describes the layers and the contract."""

from __future__ import annotations

import abc
import dataclasses
import difflib
import importlib
import importlib.util
import inspect
import json
import sys
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, Literal, Protocol, TypedDict

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError


class SpecError(ValueError):
    """A spec that must not run. ``errors`` is a list of {"field": dotted path, "message"}."""

    def __init__(self, errors: list[dict[str, str]]):
        self.errors = errors
        super().__init__("; ".join(f"{e['field']}: {e['message']}" for e in errors))

    @classmethod
    def from_validation(cls, exc: ValidationError, model: type[BaseModel] | None = None) -> SpecError:
        """The errors of a failed validation of ``model`` (default: the StrictModel the error
        is titled after, when one has that name); a range error states the field's whole
        allowed range (app/jobs/ranges.py)."""
        from app.jobs.ranges import explain_error

        model = model if model is not None else _model_named(exc.title)
        out = []
        for e in exc.errors():
            loc = ".".join(str(p) for p in e["loc"] if p not in ("function-after",)) or "spec"
            msg = e["msg"]
            if e["type"] == "extra_forbidden":
                msg = "unknown field"
            if msg.startswith("Value error, "):
                msg = msg[len("Value error, "):]
            out.append({"field": loc, "message": explain_error(model, e, msg)})
        return cls(out)


def _model_named(title: str) -> type[BaseModel] | None:
    """The one StrictModel class named ``title`` (a ValidationError names the model it
    validated, not its class), or None when no class or several have that name."""
    found, stack = [], list(StrictModel.__subclasses__())
    while stack:
        c = stack.pop()
        stack.extend(c.__subclasses__())
        if c.__name__ == title and c not in found:
            found.append(c)
    return found[0] if len(found) == 1 else None


class Cancelled(Exception):
    """Raised inside a search when the job's cancel flag is seen between generations."""


class RunContext(Protocol):
    """All a job kind may touch of the outside world."""

    artifact_dir: Path

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None: ...

    def save_checkpoint(self, state: dict[str, Any]) -> None: ...

    def load_checkpoint(self) -> dict[str, Any] | None: ...

    def is_cancelled(self) -> bool: ...

    def load_robot(self, robot_id: str) -> Any:
        """An uploaded robot by its id (app/robots/legmap.py ``Robot``: the stored, sanitised
        model, its assets and leg map), for a kind with ``user_robots``; SpecError (field
        robot) when there is none of that id."""


@dataclasses.dataclass
class JobResult:
    summary: dict[str, Any]  # JSON: what `gaitmend run --json` prints and result.json holds
    history: list[dict[str, float]]  # one row per generation
    traces: dict[str, dict[str, np.ndarray]]  # name -> per-step arrays (best, baseline, ...)
    model_xml: str  # the simulated model, exactly
    evaluations: int
    sim_steps: int


def to_jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist())
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    return x


def dumps(x: Any) -> str:
    return json.dumps(to_jsonable(x), sort_keys=False)


# -- specs ------------------------------------------------------------------------------------

# Every spec section uses this: unknown fields rejected, no type coercion ("1" is not 1,
# true is not 1, 1.5 is not an int), finite numbers only.
STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class StrictModel(BaseModel):
    """A section of a spec (damage, search, sim ...): strict, as the whole spec."""

    model_config = STRICT


class SpecBase(StrictModel):
    """What every kind's ``Spec`` declares besides its own sections.

    - ``kind``: a ``Literal[name]`` field (the discriminator of the API's spec union);
    - ``robot``: the robot it simulates (one of the kind's ``robots``);
    - ``seed``: an int field or property: every random draw of the job comes from it;
    - ``evaluations_budget``: property, the number of evaluations (simulations, or
      rollouts) the job will run in all phases, as stated in words in ``budget_formula``.

    Specs are parsed from JSON (``parse``): strict pydantic accepts a JSON array for a
    tuple field in JSON mode only, and CLI, API and bundles all hold JSON.
    """

    kind: str
    robot: str
    budget_formula: ClassVar[str] = ""
    budget_field: ClassVar[str] = "spec"  # the field to lower when the budget is over a limit

    @property
    @abc.abstractmethod
    def evaluations_budget(self) -> int:
        """Evaluations the job will run in all its phases (``budget_formula`` in words)."""

    @classmethod
    def parse(cls, data: Any):
        """Validate ``data`` (a dict as decoded from JSON); raises SpecError naming fields."""
        try:
            text = json.dumps(data, allow_nan=True)
        except (TypeError, ValueError) as e:
            raise SpecError([{"field": "spec", "message": f"not JSON data: {e}"}]) from None
        try:
            return cls.model_validate_json(text)
        except ValidationError as e:
            raise SpecError.from_validation(e, cls) from None

    @classmethod
    def __pydantic_init_subclass__(cls, **kw: Any) -> None:
        super().__pydantic_init_subclass__(**kw)
        if "kind" in cls.__dict__.get("__annotations__", {}) and not cls.budget_formula:
            raise TypeError(f"{cls.__name__}: a spec states its budget_formula in words")


# -- presentation records ---------------------------------------------------------------------

class HeadlineRow(TypedDict):
    """One number a user came for. ``better``: "higher", "lower" or None (no direction);
    ``target``: the stated target in words or None; ``met``: whether this value meets it
    (None when there is no target)."""

    label: str
    value: float | int | str | bool | None
    unit: str
    better: Literal["higher", "lower"] | None
    target: str | None
    met: bool | None


def headline_row(label: str, value: Any, unit: str = "", better: str | None = None, target: str | None = None,
                 met: bool | None = None) -> HeadlineRow:
    return HeadlineRow(label=label, value=to_jsonable(value), unit=unit, better=better, target=target,
                       met=None if met is None else bool(met))


class Table(TypedDict):
    """A table of a result: the CLI prints it, the dashboard shows it. Cells are text or
    numbers; ``notes`` are lines printed under it."""

    title: str
    columns: list[str]
    rows: list[list[Any]]
    notes: list[str]


def table(title: str, columns: list[str], rows: list[list[Any]], notes: list[str] | None = None) -> Table:
    return Table(title=title, columns=list(columns), rows=[list(r) for r in rows], notes=list(notes or []))


@dataclasses.dataclass(frozen=True)
class ReplayTrack:
    """How the replay (and the plots) show one trace: its label and its colour role in
    app/core/colors.py; ``order``: smaller first (the first is the one the camera frames)."""

    name: str
    label: str
    role: str | None
    order: int = 0

    @property
    def color(self) -> str:
        from app.core.colors import hex_color

        return hex_color(self.role, self.order)


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


# -- the kind contract -------------------------------------------------------------------------

COMMON_FILES = {
    "manifest.json": "bundle schema, job id, the full spec (every default filled in), seed, versions of gaitmend / "
                     "MuJoCo / NumPy / Python, sha256 of `robot.xml`, wall time, evaluations",
    "result.json": "the summary the job computed (`gaitmend run --json` prints the same)",
    "robot.xml": "the robot exactly as simulated (MJCF)",
    "README.md": "this file",
    "replay.viser": "3D replay: a viser scene recording (the dashboard plays it; `gaitmend replay`)",
}


class Kind(abc.ABC):
    """A job kind: one package ``app/jobs/<name>/`` and one registry line.

    Everything outside the package (CLI, API, store, worker, bundle, replay, bench,
    dashboard) reaches a kind only through these attributes and methods, never by its
    name. This class declares every member a kind may provide, each with its default:
    a kind sets the required attributes (``REQUIRED``) and implements ``run``,
    ``headline``, ``summary_tables`` and ``figures``; the rest have defaults that fit most
    kinds. A kind that sets a name the contract does not declare (a misspelt optional
    member would otherwise be ignored in silence) is refused at registration
    (``check_kind``, called by app/jobs/registry.py).

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
    history_x: ClassVar[str] = "generation"
    """history.csv's x column."""
    history_columns: ClassVar[dict[str, str]] = {}
    """history.csv: what every column means (the same across optimisers); a "best" column
    makes the default ``history_axis``."""
    trace_descriptions: ClassVar[dict[str, str]] = {}
    """trajectories/<name>.npz: what each trace is (bundle README, dashboard)."""
    figure_descriptions: ClassVar[dict[str, str]] = {}
    """plots/<stem>.svg|png: what each figure shows (bundle README, dashboard); a key
    ending in ``*`` matches every stem it starts."""
    form_open: ClassVar[tuple[str, ...] | list[str]] = ()
    """The spec groups (dotted paths, e.g. "damage", "recovery.enabled") the dashboard's
    form shows opened first; default none."""

    REQUIRED: ClassVar[tuple[str, ...]] = ("name", "title", "paper", "Spec", "robots")

    # -- the job ------------------------------------------------------------------------
    @abc.abstractmethod
    def run(self, spec: Any, ctx: RunContext) -> JobResult:
        """Run the job: report progress, checkpoint, check cancel between units of work
        (raise ``Cancelled``); same spec and seed, same numbers, also after a resume."""

    def smoke_spec(self) -> dict[str, Any] | None:
        """A spec (JSON) that runs in seconds and checkpoints at least once: the contract
        tests (tests/jobs/test_contract.py) run every kind with it."""
        return None

    def robot_info(self, robot: str) -> dict[str, Any]:
        """Details of one of ``robots`` for /api/robots and the form (legs, modules,
        parameters ...); JSON."""
        return {}

    def default_spec(self) -> SpecBase:
        """The spec with every default (``{"kind": name}`` parsed)."""
        return self.Spec.parse({"kind": self.name})

    def damage_text(self, spec: SpecBase) -> str:
        """The damage (or scenario) in words, e.g. 'lost 1,6; locked 2.femur'."""
        return "none"

    user_robots: ClassVar[bool] = False
    """Whether the kind runs on an uploaded robot (its spec's ``robot`` is the robot's id;
    the run reads it with ``RunContext.load_robot``): /api/robots lists the kind for them."""

    def user_robot_error(self, spec: SpecBase, legs: dict[str, Any]) -> str | None:
        """Why ``spec`` cannot run on the uploaded robot of leg map ``legs`` (JSON): a leg or
        joint it names that the map lacks, a robot that cannot stand ...; None when it can.
        The API asks before it queues the job."""
        return None

    damage_label: ClassVar[str] = "Damage"
    """What ``damage_text`` words, as the job page labels it ("Damage", "Scenario", "Task")."""

    # -- presentation -------------------------------------------------------------------
    @abc.abstractmethod
    def headline(self, summary: dict) -> list[HeadlineRow]:
        """The few numbers a user came for, with units, direction and target."""

    @abc.abstractmethod
    def summary_tables(self, summary: dict) -> list[Table]:
        """The result as tables (`gaitmend run` prints them; the dashboard shows them)."""

    @abc.abstractmethod
    def figures(self, result: JobResult, out_dir: Path) -> list[Path]:
        """Write the kind's plots into ``out_dir``; returns the files written."""

    def metric_names(self, summary: dict) -> dict[str, tuple[str, str, float]]:
        """Metric keys of the summary's control and robustness records -> (label, unit, scale
        to that unit), e.g. {"y_f_m": ("forward", "cm", 100.0)}: the evidence tables show
        these; a key not listed is worded from its name (app/jobs/viewkit.py). Default: none."""
        return {}

    def verdict_scores(self, summary: dict) -> list[dict[str, Any]]:
        """The numbers the method is compared with its controls on, in order (a tie on the
        first is decided by the next): ``app.jobs.verdict.score(...)`` records. Default: the
        first headline row with a direction that is the nominal value of a metric the
        robustness block spreads (``verdict.generic_scores``)."""
        from app.jobs.verdict import generic_scores

        return generic_scores(summary, self.headline(summary))

    def verdict(self, summary: dict) -> dict[str, Any]:
        """Did the method work, at a glance (the job page's first block, the list's row, the
        study page): the target and whether it is met, the method against each control at
        the same budget (beat / tied / lost, by how much), robustness k of n by group.
        Default: ``app.jobs.verdict.verdict_of`` over the headline, the evidence blocks and
        ``verdict_scores``; a kind overrides it only where that rule is wrong."""
        from app.jobs.verdict import verdict_of

        return verdict_of(summary, self.headline(summary), self.verdict_scores(summary),
                          primary=self.list_headline(summary))

    def list_headline(self, summary: dict) -> HeadlineRow | None:
        """The one headline row the jobs list shows for a succeeded job. Default: the first
        row with a direction and a value (else the first row)."""
        from app.jobs.verdict import list_row

        return list_row(self.headline(summary))

    def page_tables(self, summary: dict) -> list[Table]:
        """The ``summary_tables`` the dashboard shows beside the shared controls and
        robustness tables (which it draws once, from the evidence blocks). Default: every
        table but those titled controls... or robustness... when the summary carries that
        block."""
        import re

        skip = [w for w in ("controls", "robustness") if summary.get(w)]
        return [t for t in self.summary_tables(summary)
                if not any(re.match(rf"{w}\b", t["title"].strip(), re.I) for w in skip)]

    def progress_text(self, info: dict[str, Any]) -> str:
        """One line for a progress bar from the ``info`` the kind's run reports."""
        return "  ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                         for k, v in info.items() if isinstance(v, (int, float, str, bool)))[:80]

    def replay_style(self, trace_names: list[str]) -> list[ReplayTrack]:
        """The traces the replay shows (those with ``qpos``), in order, with labels and
        colour roles. Default: every given trace in the given order, palette colours."""
        return [ReplayTrack(n, n, None, i) for i, n in enumerate(trace_names)]

    def bundle_rows(self, files: list[str]) -> dict[str, str]:
        """{path: description} for exactly ``files`` (the bundle's members)."""
        out = {}
        for f in files:
            out[f] = self.describe_file(f)
        return out

    def bundle_files(self, spec: Any, result: JobResult) -> dict[str, str | bytes]:
        """Files of the kind's own the bundle adds, {path in the zip: content} (e.g. what a lab
        needs to run the answer on the hardware); ``describe_file`` says what each is.
        Default: none."""
        return {}

    def describe_file(self, path: str) -> str:
        """What one bundle member is: the common files, history.csv from ``history_columns``,
        traces from ``trace_descriptions``, plots from ``figure_descriptions``."""
        if path in COMMON_FILES:
            return COMMON_FILES[path]
        if path == "history.csv":
            cols = "; ".join(f"`{k}`: {v}" for k, v in self.history_columns.items())
            return f"one row per {self.history_x}" + (f": {cols}" if cols else "")
        p = Path(path)
        if p.parent.name == "trajectories":
            what = self.trace_descriptions.get(p.stem, f"the `{p.stem}` trace")
            fmt = "per-step arrays (NumPy .npz)" if p.suffix == ".npz" else \
                "the same, flat: one column per 1-D array or component (CSV)"
            return f"{what}: {fmt}"
        if p.parent.name == "plots":
            stem = p.stem
            what = self.figure_descriptions.get(stem)
            if what is None:
                what = next((v for k, v in self.figure_descriptions.items() if k.endswith("*") and stem.startswith(k[:-1])),
                            f"figure `{stem}`")
            return f"{what} ({p.suffix[1:].upper()})"
        return "extra file"

    # -- studies --------------------------------------------------------------------------
    def named_values(self) -> dict[str, dict[str, list[Any]]]:
        """Named value sets a study grid may use instead of a list, by dotted spec path:
        {"damage.lost_legs": {"all_feasible_1_and_2": [[1], [2], ...]}}."""
        return {}

    def infeasible_reason(self, data: dict[str, Any]) -> str | None:
        """Why a spec (a dict, before validation) describes a robot that cannot run at all
        (a study lists such points instead of queueing them), else None. Malformed input is
        the Spec's to reject: return None for it."""
        return None

    def builtin_studies(self) -> dict[str, dict[str, Any]]:
        """The kind's built-in studies: {name: study spec (JSON)}, the paper's table first.
        A name is unique over all kinds; each study's base is a job of this kind.
        app/studies/catalog.py gathers them over the registry (`gaitmend study run NAME`,
        `gaitmend reproduce <kind>-study`, /api/studies/builtin). Default: none."""
        return {}

    # -- reproduction, benchmarks, dashboard ----------------------------------------------
    def experiments(self) -> list[Experiment]:
        """The paper reproductions, the first one the kind's ``gaitmend reproduce <kind>``;
        default none."""
        return []

    def bench(self) -> list[BenchEntry]:
        """The figure groups ``gaitmend bench`` measures for this kind; default none."""
        return []

    def study_views(self, study: dict, points: list[dict]) -> list[dict]:
        """Panels (the shape of ``views``) drawn from a whole study of this kind, for the
        study's page, before the generic per-metric charts: e.g. a polar success rate over
        swept directions. ``study``: the study spec; ``points``: {"index", "overrides",
        "spec", "status", "summary", "error"} per point (summary None unless succeeded).
        Default: none."""
        return []

    def views(self, summary: dict, traces: dict[str, dict[str, Any]]) -> list[dict]:
        """The kind's dashboard page, in order: panels {"id", "title", "caption", and
        "figure": {"data", "layout"} (a plotly figure) or "table": {"columns", "rows"}}, cells
        plain values or {"value", "unit", "met", "better", "note"} (app/jobs/viewkit.py builds
        both); a bare plotly figure dict is accepted too. ``traces``: the bundle's
        trajectories by name (lazy .npz mappings)."""
        return []

    def history_axis(self, spec: dict) -> dict | None:
        """What history.csv's columns mean for a job of ``spec`` (the dict as stored), for
        the job and compare pages: {"x": the x column, "x_note": what it counts, "y": the
        objective's label, "better": "higher", "lower" or None, "series": {column: label}
        to draw}. None when the history holds no objective (e.g. one row per run).
        Default: read from ``history_columns`` (a column's text up to its first ';' is its
        label), direction unknown; None without a "best" column."""
        cols = self.history_columns or {}
        if "best" not in cols:
            return None
        series = {k: cols[k].split(";")[0] for k in ("best", "generation_best", "mean", "worst") if k in cols}
        return {"x": self.history_x, "x_note": cols.get(self.history_x), "y": series["best"], "better": None,
                "series": series}

    def form(self) -> list[dict[str, Any]]:
        """The fields a user sets in the dashboard's form, derived from the Spec's JSON
        schema: [{"path": "search.population", "type", "default", "minimum", "maximum",
        "enum", "title", "description"}]; a kind may trim or order it."""
        return form_fields(self.Spec)

    def __repr__(self) -> str:
        return f"<kind {self.name}>"


class Deferred:
    """A member found in one of the kind package's own modules when first used, for modules
    slow to import (run, experiments, bench): ``Deferred(".run", "run")`` calls the ``run``
    function of the package's ``run`` module; with ``value=True`` the member returns the
    attribute itself (``Deferred(".experiments", "EXPERIMENTS", value=True)``). Registration
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

_DECLARING = (Kind, PackageKind)  # the classes that declare the contract's members


def contract_members(kind_cls: type[Kind]) -> dict[str, Any]:
    """{name: its declaration} of every member ``kind_cls`` may set: those Kind declares,
    and PackageKind's too for a PackageKind."""
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


def form_fields(spec_cls: type[BaseModel]) -> list[dict[str, Any]]:
    """Flatten a Spec's JSON schema into leaf fields with their bounds and defaults."""
    schema = spec_cls.model_json_schema()
    defs = schema.get("$defs", {})
    out: list[dict[str, Any]] = []

    def resolve(node: dict) -> dict:
        while "$ref" in node:
            node = defs[node["$ref"].split("/")[-1]]
        return node

    def walk(node: dict, path: str, default: Any) -> None:
        node = resolve(node)
        if node.get("type") == "object" and "properties" in node:
            for key, sub in node["properties"].items():
                sub_default = default.get(key) if isinstance(default, dict) else None
                if "default" in sub:
                    sub_default = sub["default"]
                walk(sub, f"{path}.{key}" if path else key, sub_default)
            return
        options = node.get("anyOf") or node.get("oneOf")
        field = {"path": path, "title": node.get("title", path.split(".")[-1]),
                 "description": node.get("description"), "default": default}
        if options:
            real = [resolve(o) for o in options if o.get("type") != "null"]
            field["nullable"] = len(real) < len(options)
            if len(real) == 1:
                node = real[0] | {k: v for k, v in node.items() if k not in ("anyOf", "oneOf")}
            else:
                field["type"] = "union"
                field["options"] = real
                out.append(field)
                return
        for key in ("type", "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "const",
                    "minItems", "maxItems", "items"):
            if key in node:
                field[key] = node[key]
        out.append(field)

    walk(schema, "", None)
    return out


class MemoryContext:
    """A run context with no outside world: checkpoints kept in memory, no progress shown,
    never cancelled (experiments, benchmarks, `gaitmend run` wraps it with a progress bar)."""

    def __init__(self, artifact_dir: Path | None = None, robots: Callable[[str], Any] | None = None):
        self.artifact_dir = Path(artifact_dir) if artifact_dir is not None else Path(".")
        self._ckpt: dict[str, Any] | None = None
        self._robots = robots  # robot id -> the uploaded robot (the CLI reads this machine's store)

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        pass

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        self._ckpt = state

    def load_checkpoint(self) -> dict[str, Any] | None:
        return self._ckpt

    def is_cancelled(self) -> bool:
        return False

    def load_robot(self, robot_id: str) -> Any:
        if self._robots is None:
            raise SpecError([{"field": "robot", "message": f"no uploaded robot {robot_id!r}: this run has no robots"}])
        return self._robots(robot_id)

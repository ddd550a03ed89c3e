"""What presents a result: the part of the kind contract the CLI, the bundle writer, the
replay and the dashboard read (``PresentsResult``), the records it returns (``HeadlineRow``,
``Table``, ``ReplayTrack``), the bundle's common files and the form's fields derived from a
spec (``form_fields``). app/jobs/base.py composes this part into ``Kind`` and re-exports
every name."""

from __future__ import annotations

import abc
import dataclasses
from pathlib import Path
from typing import Any, ClassVar, Literal, TypedDict

from pydantic import BaseModel

from app.jobs.job_result import JobResult, to_jsonable
from app.jobs.spec_base import SpecBase


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


COMMON_FILES = {
    "manifest.json": "bundle schema, job id, the full spec (every default filled in), seed, versions of gaitmend / "
                     "MuJoCo / NumPy / Python, sha256 of `robot.xml`, wall time, evaluations",
    "result.json": "the summary the job computed (`gaitmend run --json` prints the same)",
    "robot.xml": "the robot exactly as simulated (MJCF)",
    "README.md": "this file",
    "replay.viser": "3D replay: a viser scene recording (the dashboard plays it; `gaitmend replay`)",
}


class PresentsResult(abc.ABC):
    """What presents a result of the kind: the headline, tables and figures (required),
    and the defaults the CLI, the bundle README, the replay, the verdict and the dashboard
    read: descriptions of every history column, trace and figure, the job and study pages,
    the form.

    Invariants:
        - Every hook is a pure function of what it is given (a stored summary, traces, a
          spec dict, file names): it simulates nothing, writes nothing but ``figures``'
          files into the folder it is given, and gives the same answer for the same input,
          so a page or a bundle README drawn twice is the same.
        - A summary is read as stored (JSON: lists, not arrays); a key a hook does not know
          is passed over, so summaries of older versions still render.
        - ``bundle_rows`` describes exactly the files it is given, no more, no fewer.

    Ownership:
        - The kind owns what its numbers mean (labels, units, which way is better, the
          target) and how its traces look; the callers own the layout: the CLI prints the
          tables, app/results/ writes the bundle and replay, app/api/ and web/ draw the
          panels, and the shared controls and robustness blocks are drawn once for every
          kind from the evidence records (app/jobs/records.py, app/jobs/verdict.py).

    Raises:
        - Nothing for a summary the kind's own ``run`` wrote; a malformed summary may raise
          ``KeyError`` or ``TypeError`` (the caller reports the job's page as broken
          rather than guessing).
    """

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

    def damage_text(self, spec: SpecBase) -> str:
        """The damage (or scenario) in words, e.g. 'lost 1,6; locked 2.femur'."""
        return "none"

    damage_label: ClassVar[str] = "Damage"
    """What ``damage_text`` words, as the job page labels it ("Damage", "Scenario", "Task")."""

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

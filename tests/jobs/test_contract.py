"""The kind contract (app/jobs/base.py), checked on every registered kind and on a small
kind defined in tests/kinds/ (registered through GAITMEND_EXTRA_KINDS, no edit to app/):
strict specs, determinism, resume after a kill, cancel, bundle README, presentation."""

from __future__ import annotations

import copy
import io
import json
import math
import re
import zipfile

import numpy as np
import pytest
from rich.console import Console

from app.jobs import registry
from app.jobs.base import Cancelled, JobResult, Kind, SpecError, dumps

EXTRA = "ballistic:KIND"


@pytest.fixture(scope="module", autouse=True)
def test_kind_registered():
    """The test kind joins the registry as a worker would see it (tests/conftest.py puts
    tests/kinds on the path); other test modules see the usual kinds only."""
    before = dict(registry.KINDS)
    registry._load_extra(EXTRA)
    yield
    registry.KINDS.clear()
    registry.KINDS.update(before)


def _names() -> list[str]:
    import ballistic

    return [*registry.KINDS, ballistic.KIND.name] if ballistic.KIND.name not in registry.KINDS else list(registry.KINDS)


KIND_NAMES = _names()


@pytest.fixture(params=KIND_NAMES)
def kind(request) -> Kind:
    return registry.get_kind(request.param)


class Ctx:
    """A run context that records what the kind reports and can play a kill or a cancel."""

    def __init__(self, ckpt=None, kill_after_saves=None, cancel_after_progress=None):
        self.artifact_dir = None
        self._ckpt = copy.deepcopy(ckpt)
        self.saves = 0
        self.kill_after_saves = kill_after_saves
        self.cancel_after_progress = cancel_after_progress
        self.infos: list[dict] = []
        self.progress_after_cancel = 0
        self.cancelled = False

    def progress(self, done, total, info):
        assert 0 <= done <= total, (done, total)
        json.dumps(info)  # progress info is JSON
        self.infos.append(info)
        if self.cancelled:
            self.progress_after_cancel += 1
        if self.cancel_after_progress is not None and len(self.infos) >= self.cancel_after_progress:
            self.cancelled = True

    def save_checkpoint(self, state):
        self._ckpt = json.loads(json.dumps(state))  # as stored in the jobs table: JSON, no pickle
        self.saves += 1
        if self.kill_after_saves is not None and self.saves >= self.kill_after_saves:
            raise KeyboardInterrupt  # the worker dies right after the checkpoint is written

    def load_checkpoint(self):
        return copy.deepcopy(self._ckpt)

    def is_cancelled(self):
        return self.cancelled


_RUNS: dict[str, tuple] = {}


def smoke(kind: Kind):
    """The kind's smoke spec run once, with its context (cached per test session)."""
    if kind.name not in _RUNS:
        data = kind.smoke_spec()
        assert data is not None, f"kind {kind.name} gives no smoke_spec() for the contract tests"
        spec = registry.parse_spec(data)
        ctx = Ctx()
        _RUNS[kind.name] = (spec, kind.run(spec, ctx), ctx)
    return _RUNS[kind.name]


def comparable(res: JobResult):
    s = json.loads(dumps(res.summary))
    s.pop("timing", None)
    return s, json.loads(dumps(res.history)), res.model_xml, res.evaluations, res.sim_steps


def assert_same(a: JobResult, b: JobResult):
    assert comparable(a) == comparable(b)
    assert set(a.traces) == set(b.traces)
    for name in a.traces:
        assert set(a.traces[name]) == set(b.traces[name])
        for k in a.traces[name]:
            np.testing.assert_array_equal(np.asarray(a.traces[name][k]), np.asarray(b.traces[name][k]),
                                          err_msg=f"trace {name}.{k}")


# -- the spec -----------------------------------------------------------------------------------

def test_the_default_spec_validates_and_states_its_budget(kind):
    spec = kind.default_spec()
    assert spec.kind == kind.name and isinstance(spec.seed, int)
    assert spec.robot in kind.robots, f"{spec.robot} not among the robots {kind.name} serves"
    assert isinstance(spec.evaluations_budget, int) and spec.evaluations_budget > 0
    assert type(spec).budget_formula and type(spec).budget_field
    again = registry.parse_spec(spec.model_dump(mode="json"))  # a stored spec parses back to itself
    assert again == spec


def _leaves(kind: Kind, types: tuple[str, ...]) -> list[str]:
    """Every field of the kind's form of one of ``types``; a kind without one fails (every
    kind has numbers and integers today: one that had none would be checked by nothing)."""
    paths = [f["path"] for f in kind.form() if f.get("type") in types]
    assert paths, f"{kind.name} has no {types} field for the contract to check"
    return paths


def _leaf(kind: Kind, types: tuple[str, ...]) -> str:
    paths = _leaves(kind, types)
    return next((p for p in paths if p != "seed" and "." in p), paths[0])


def _set(data: dict, path: str, value) -> dict:
    data = copy.deepcopy(data)
    node = data
    *head, last = path.split(".")
    for key in head:
        node = node.setdefault(key, {})
    node[last] = value
    return data


def _rejected(data: dict, field: str) -> str:
    with pytest.raises(SpecError) as e:
        registry.parse_spec(data)
    fields = [x["field"] for x in e.value.errors]
    assert any(f == field or f.startswith(field + ".") for f in fields), (field, e.value.errors)
    return " ".join(x["message"] for x in e.value.errors)


def test_an_unknown_field_is_rejected_by_name(kind):
    base = {"kind": kind.name}
    assert "unknown field" in _rejected(base | {"gravity": 3}, "gravity")
    section = _leaf(kind, ("integer", "number", "boolean", "string")).rsplit(".", 1)[0]
    if section and "." not in section and section in kind.Spec.model_fields:
        assert "unknown field" in _rejected(_set(base, f"{section}.gravity", 3), f"{section}.gravity")


@pytest.mark.parametrize("bad", ["7", True, [1]])
def test_a_wrong_type_is_rejected_by_name(kind, bad):
    """Every integer and number field of the form, not one: a string, a boolean or a list is
    refused under the field's own path with the type it wanted."""
    typed = {f["path"]: f["type"] for f in kind.form() if f.get("type") in ("integer", "number")}
    for path in _leaves(kind, ("integer", "number")):
        message = _rejected(_set({"kind": kind.name}, path, bad), path)
        assert f"valid {typed[path]}" in message, (path, message)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_number_is_rejected_by_name(kind, bad):
    for path in _leaves(kind, ("number",)):
        assert "finite" in _rejected(_set({"kind": kind.name}, path, bad), path), path


def test_an_integer_field_refuses_a_float(kind):
    """2.5 in any integer field is refused as not an integer (not rounded, not truncated to
    2), under that field's path."""
    for path in _leaves(kind, ("integer",)):
        message = _rejected(_set({"kind": kind.name}, path, 2.5), path)
        assert "valid integer" in message, (path, message)


# -- the run --------------------------------------------------------------------------------------

def test_same_spec_and_seed_give_bit_identical_results(kind):
    spec, first, ctx = smoke(kind)
    assert ctx.saves >= 1, f"{kind.name} never checkpointed: a killed job would start again"
    assert first.evaluations <= spec.evaluations_budget, \
        f"{kind.name} ran {first.evaluations} evaluations, its spec declares {spec.evaluations_budget}"
    assert_same(first, kind.run(spec, Ctx()))


def test_a_run_killed_after_a_checkpoint_resumes_bit_identically(kind):
    spec, full, _ = smoke(kind)
    ctx = Ctx(kill_after_saves=1)
    with pytest.raises(KeyboardInterrupt):
        kind.run(spec, ctx)
    resumed_ctx = Ctx(ckpt=ctx.load_checkpoint())
    resumed = kind.run(spec, resumed_ctx)
    assert_same(full, resumed)


def test_cancel_stops_within_one_generation_or_run(kind):
    spec, _, _ = smoke(kind)
    ctx = Ctx(cancel_after_progress=1)
    with pytest.raises(Cancelled):
        kind.run(spec, ctx)
    assert ctx.progress_after_cancel <= 1, f"{ctx.progress_after_cancel} units of work after the cancel"


# -- presentation ---------------------------------------------------------------------------------

def test_the_bundle_readme_lists_exactly_the_files_it_holds(kind, tmp_path):
    from app.results.bundle import write_bundle

    spec, res, _ = smoke(kind)
    path = write_bundle(tmp_path / "b.zip", "job-1", spec, res)
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
        readme = z.read("README.md").decode()
        manifest = json.loads(z.read("manifest.json"))
    listed = dict(re.findall(r"^\| `([^`]+)` \| (.+) \|$", readme, flags=re.M))
    assert set(listed) == names
    assert all(d.strip() and d != "extra file" for d in listed.values()), listed
    assert manifest["kind"] == kind.name and manifest["evaluations"] == res.evaluations
    assert kind.title in readme
    assert any(n.startswith("plots/") for n in names), "a kind writes at least one figure"
    # the verdict, as the job page and `gaitmend run` state it (issue 46: held-out figure first)
    assert f"## Verdict\n\nVerdict: {kind.verdict(json.loads(dumps(res.summary)))['sentence']}\n" in readme


def test_headline_tables_progress_and_history_render(kind):
    from app.cli.common import print_tables

    spec, res, ctx = smoke(kind)
    summary = json.loads(dumps(res.summary))  # what the API and the bundle hold
    rows = kind.headline(summary)
    assert rows, f"{kind.name} has no headline"
    for r in rows:
        assert set(r) == {"label", "value", "unit", "better", "target", "met"}
        assert r["better"] in ("higher", "lower", None) and r["met"] in (True, False, None)
        assert r["met"] is None or r["target"], "a met flag needs the target it was checked against"
    json.dumps(rows)
    tables = kind.summary_tables(summary)
    assert tables
    for t in tables:
        assert all(len(row) == len(t["columns"]) for row in t["rows"]), t["title"]
    out = io.StringIO()
    print_tables(tables, Console(file=out, width=200))
    assert tables[0]["title"].split(":")[0] in out.getvalue()
    for info in ctx.infos:
        assert isinstance(kind.progress_text(info), str)
    assert kind.damage_text(spec)
    described = set(kind.history_columns)
    for row in res.history:
        assert kind.history_x in row
        assert set(row) <= described, f"undescribed history columns: {set(row) - described}"


def test_replay_views_form_experiments_and_bench_are_well_formed(kind):
    _, res, _ = smoke(kind)
    replayable = [n for n, tr in res.traces.items() if "qpos" in tr]
    tracks = kind.replay_style(replayable)
    assert {t.name for t in tracks} <= set(replayable)
    assert all(t.color.startswith("#") and t.label for t in tracks)
    for panel in kind.views(json.loads(dumps(res.summary)), res.traces):
        if "table" in panel:
            assert {"columns", "rows"} <= set(panel["table"]) and {"id", "title"} <= set(panel)
        elif "figure" in panel:
            assert "data" in panel["figure"] and {"id", "title"} <= set(panel)
        else:
            assert "data" in panel, "a panel, or a bare plotly figure"
        json.dumps(panel)
    paths = [f["path"] for f in kind.form()]
    assert "kind" in paths and len(paths) == len(set(paths))
    for e in kind.experiments():
        e.Params()  # every option has a default
        assert e.name and e.help
    for b in kind.bench():
        assert b.name and callable(b.run)
    for robot in kind.robots:
        json.dumps(kind.robot_info(robot))

"""The built-in studies against real runs of their kinds: every metric a study reports is
a finite number (or a bool) in the summary of a real job of the study's first point, run
at its kind's smoke budget; each kind ships its own (app/jobs/<kind>/studies/, gathered by
app/studies/catalog.py); and `gaitmend reproduce <kind>-study` offers each kind's built-in
studies."""

from __future__ import annotations

import json
import math
from importlib import resources

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.jobs.base import MemoryContext, dumps
from app.jobs.registry import KINDS, get_kind, parse_spec
from app.studies.aggregate import aggregate
from app.studies.catalog import builtin_studies, builtin_study, kind_studies
from app.studies.spec import expand, get_path, set_path
from app.studies.views import metric_name, study_views


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


@pytest.mark.parametrize("name", list(builtin_studies()))
def test_every_reported_metric_is_a_number_in_a_real_run_of_the_first_point(name, tmp_path):
    study = builtin_study(name)
    point = expand(study).points[0]
    kind = get_kind(point["kind"])
    spec = _merge(point["spec"], kind.smoke_spec())  # the smoke budget ...
    for path, value in point["overrides"].items():  # ... at the study's first point
        set_path(spec, path, value)
    result = kind.run(parse_spec(spec), MemoryContext(tmp_path))
    summary = json.loads(dumps(result.summary))  # what a worker stores
    unjudged = set()
    for metric in study["report"]["metrics"]:
        v = get_path(summary, metric)
        head, _, key = metric.rpartition(".")
        if v is None and key in (get_path(summary, head) if head else summary):
            unjudged.add(metric)  # there, but not judged (recovery: the smoke walk is shorter than its target needs)
            continue
        assert isinstance(v, (bool, int, float)) and math.isfinite(v), (name, metric, v)
    for path in study["report"].get("group_by", []):
        assert get_path(point["spec"], path) is not None, (name, path)
    # the study page's plots from this point: one chart per metric, plus the kind's own
    rows = [{"index": 0, "overrides": point["overrides"], "spec": json.loads(json.dumps(spec)),
             "status": "succeeded", "summary": summary, "error": None}]
    agg = aggregate(rows, study["report"].get("group_by", []), study["report"]["metrics"])
    panels = {p["id"]: p for p in study_views(study, rows, agg)}
    for i, metric in enumerate(study["report"]["metrics"]):  # in the unit the page names (the kind's metric_names)
        if metric in unjudged:
            continue
        scale = metric_name(kind, metric, summary)[2]
        assert panels[f"metric-{i}"]["figure"]["data"][0]["y"] == [pytest.approx(scale * float(get_path(summary, metric)))]
    if name == "tipping_directions":  # the polar success rate over directions
        polar = panels["study-sweep"]["figure"]["data"]
        assert polar[0]["theta"] == [0.0] and polar[0]["r"] == [100.0 * (not summary["runs"]["recovery"]["tipped"])]
        assert polar[1]["r"][0] == 100.0 * summary["runs"]["no_recovery"]["tipped"]


def test_each_kind_ships_its_studies_in_its_package_paper_table_first():
    catalog = builtin_studies()
    assert list(catalog) == [n for k in KINDS.values() for n in k.builtin_studies()]  # registry order
    for kind in KINDS.values():
        studies = kind.builtin_studies()
        assert studies, f"{kind.name} has no paper study"
        assert all(s["base"]["kind"] == kind.name for s in studies.values())
        assert list(studies) == kind_studies(kind.name)
        folder = resources.files(type(kind).__module__).joinpath("studies")
        assert sorted(studies) == sorted(f.name.removesuffix(".json") for f in folder.iterdir()
                                         if f.name.endswith(".json"))
        order = getattr(kind, "study_order", ())
        assert list(studies) == [*order, *sorted(set(studies) - set(order))]
    assert kind_studies("recovery")[:2] == ["recovery_table2", "recovery_atlas"]  # Table II, then the atlas
    assert kind_studies("nope") == [] and builtin_study("nope") is None
    assert builtin_study("recovery_table2") is not builtin_study("recovery_table2")  # a fresh copy each call


def test_reproduce_offers_each_kinds_builtin_studies_and_names_a_bad_one():
    runner = CliRunner()
    kinds = {s["base"]["kind"] for s in builtin_studies().values()}
    assert kinds == set(KINDS)  # every kind has a paper study
    for kind in kinds:
        names = kind_studies(kind)
        assert names and all(builtin_study(n)["base"]["kind"] == kind for n in names)
        r = runner.invoke(cli, ["reproduce", f"{kind}-study", "--help"])
        assert r.exit_code == 0 and names[0] in r.output, r.output
    r = runner.invoke(cli, ["reproduce", "recovery-study", "tipping_directions"])
    assert r.exit_code == 2
    assert "NAME" in r.output and "recovery_table2" in r.output


def test_a_study_of_short_recovery_walks_says_not_judged_not_no_target(tmp_path):
    """Recovery's target is rates scaled to the walk; a walk under 3 s is not judged unless
    it fell. The study's verdict said "no target" for such points (the kind has one): it
    says they were not judged, and the target's words for their walk."""
    kind = get_kind("recovery")
    spec = _merge(kind.smoke_spec(), {"sim": {"duration_s": 0.5}})
    parsed = parse_spec(spec)
    summary = json.loads(dumps(kind.run(parsed, MemoryContext(tmp_path)).summary))
    spec = parsed.model_dump(mode="json")  # what a job stores (the robot named)
    assert kind.verdict(summary)["target"]["met"] is None and not summary["best"]["metrics"]["fell"]
    study = {"name": "short", "base": spec, "grid": {"search.seed": [0, 1]},
             "report": {"group_by": [], "metrics": ["headline.primary"]}}
    rows = [{"index": i, "overrides": {"search.seed": i}, "spec": spec, "status": "succeeded", "summary": summary,
             "error": None} for i in range(2)]
    agg = aggregate(rows, [], study["report"]["metrics"])
    verdict = {p["id"]: p for p in study_views(study, rows, agg)}["verdict"]
    cells = {r[1]["text"] if isinstance(r[1], dict) else r[1] for r in verdict["table"]["rows"]}
    assert cells == {"not judged (walk too short)"}, cells
    note = verdict["table"]["rows"][0][1]["note"]
    assert "0.5 s walk is too short to judge" in note and ">= 3 s" in note, note

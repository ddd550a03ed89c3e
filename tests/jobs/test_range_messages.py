"""A range error states the field's whole allowed range (app/jobs/ranges.py), not only the
bound it broke: every kind's spec, lists, the body parser's non-finite numbers, studies and
`gaitmend reproduce` options. The ``field`` of each error is unchanged."""

from __future__ import annotations

import copy

import pytest
import typer
from pydantic import BaseModel, Field

from app.api.body import BodyError, parse_json
from app.jobs import ranges, registry
from app.jobs.base import Experiment, SpecError


def _num(v) -> str:
    return str(int(v)) if float(v).is_integer() and abs(v) < 1e16 else repr(float(v))


def _bounded(kind, n: int = 5) -> list[dict]:
    """Up to ``n`` numeric fields of the kind's form with both bounds, spread over the spec."""
    fields = [f for f in kind.form() if f.get("type") in ("integer", "number")
              and ("maximum" in f or "exclusiveMaximum" in f) and ("minimum" in f or "exclusiveMinimum" in f)]
    step = max(1, len(fields) // n)
    return fields[::step][:n]


def _set(data: dict, path: str, value) -> dict:
    data = copy.deepcopy(data)
    node = data
    *head, last = path.split(".")
    for key in head:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    node[last] = value
    return data


def _errors(data: dict) -> list[dict]:
    with pytest.raises(SpecError) as e:
        registry.parse_spec(data)
    return e.value.errors


@pytest.mark.parametrize("name", list(registry.KINDS))
def test_a_value_above_the_maximum_names_both_bounds(name):
    kind = registry.KINDS[name]
    fields = _bounded(kind)
    assert fields, f"{name} has no bounded numeric field"
    base = kind.default_spec().model_dump(mode="json")
    for f in fields:
        lo = f.get("minimum", f.get("exclusiveMinimum"))
        hi = f.get("maximum", f.get("exclusiveMaximum"))
        above = int(hi) + 1 if f["type"] == "integer" else float(hi) + max(1.0, abs(hi))
        errors = _errors(_set(base, f["path"], above))
        mine = [e for e in errors if e["field"] == f["path"]]
        assert mine, (f["path"], errors)
        msg = mine[0]["message"]
        leaf = f["path"].rsplit(".", 1)[-1]
        assert "allowed:" in msg and _num(lo) in msg and _num(hi) in msg and leaf in msg, (f["path"], msg)
        assert msg.index("; allowed:") > 0, msg  # what was wrong first (the bound broken), then the range


@pytest.mark.parametrize("name", list(registry.KINDS))
def test_a_non_finite_value_states_the_range(name):
    kind = registry.KINDS[name]
    f = next(f for f in _bounded(kind) if f["type"] == "number")
    errors = _errors(_set(kind.default_spec().model_dump(mode="json"), f["path"], float("inf")))
    msg = next(e["message"] for e in errors if e["field"] == f["path"])
    assert "finite" in msg and "allowed:" in msg and _num(f.get("maximum", f.get("exclusiveMaximum"))) in msg, msg


@pytest.mark.parametrize("patch, field, words", [
    ({"search": {"population": 2}}, "search.population",
     "Input should be greater than or equal to 4; allowed: 4 <= population <= 1000"),
    ({"search": {"population": 1001}}, "search.population", "allowed: 4 <= population <= 1000"),
    ({"sim": {"duration_s": 0.1}}, "sim.duration_s", "allowed: 0.5 <= duration_s <= 120 (in s)"),
    ({"damage": {"lost_legs": [7]}}, "damage.lost_legs.0", "allowed: 1 <= lost_legs[0] <= 6"),
    ({"damage": {"lost_legs": [1, 2, 3, 4, 5, 6, 1]}}, "damage.lost_legs", "allowed: at most 6 items"),
    ({"damage": {"weak_joints": [{"leg": 2, "joint": "coxa", "torque_scale": 0}]}},
     "damage.weak_joints.0.torque_scale", "allowed: 0 < torque_scale <= 1"),
    ({"damage": {"locked_joints": [{"leg": 2, "joint": "coxa", "angle_deg": 200}]}},
     "damage.locked_joints.0.angle_deg", "allowed: -180 <= angle_deg <= 180 (in deg)"),
    ({"objective": {"weights": [1, 1, 1]}}, "objective.weights", "allowed: exactly 5 items"),
    ({"objective": {"weights": [1, 1, 10, 100, 1e7]}}, "objective.weights.4", "allowed: 0 <= weights[4] <= 1000000"),
    ({"bounds": {"x0_m": [0, 2]}}, "bounds.x0_m.1", "allowed: -1 <= x0_m[1] <= 1 (in m)"),
    ({"bounds": {"y0_m": {"3": [0, 2]}}}, "bounds.y0_m.3.1", "allowed: -1 <= y0_m[3][1] <= 1 (in m)"),
    ({"robust": {"models": []}}, "robust.models", "allowed: 1 to 7 items"),
    ({"robot": "r" * 65}, "robot", "allowed: at most 64 characters"),
])
def test_recovery_messages(patch, field, words):
    errors = _errors({"kind": "recovery", **patch})
    assert any(e["field"] == field and words in e["message"] for e in errors), errors


def test_a_tagged_union_member_and_a_unit_in_the_description():
    errors = _errors({"kind": "tipping", "scenario": {"type": "tilt", "rate_deg_s": 99}})
    assert errors == [{"field": "scenario.tilt.rate_deg_s", "message": "Input should be less than or equal to 30; "
                                                                       "allowed: 0 < rate_deg_s <= 30 (in deg/s)"}]

    class P(BaseModel):
        directions: float = Field(0.0, ge=0, le=360, description="downhill directions (deg), comma-separated")
        change_at: float = Field(1.0, ge=1, le=200, description="18 s falls inside a transfer")
        plans: int = Field(20, ge=1, le=500, description="reuse plans per scenario (paper: 20)")

    assert ranges.allowed(P, ("directions",), "less_than_equal") == "0 <= directions <= 360 (in deg)"
    assert ranges.allowed(P, ("change_at",), "less_than_equal") == "1 <= change_at <= 200 (in s)"
    assert ranges.allowed(P, ("plans",), "less_than_equal") == "1 <= plans <= 500"
    assert ranges.allowed(P, ("nothing",), "less_than_equal") is None


def test_the_schema_is_read_once_per_model():
    ranges._schema.cache_clear()
    ranges._field_at.cache_clear()
    for _ in range(3):
        _errors({"kind": "recovery", "search": {"population": 2}})
    assert ranges._schema.cache_info().misses == 1


@pytest.mark.parametrize("raw, field", [
    (b'{"kind":"recovery","sim":{"duration_s":1e400}}', "sim.duration_s"),
    (b'{"kind":"recovery","sim":{"duration_s":NaN}}', "sim.duration_s"),
    (b'{"name":"s","base":{"kind":"recovery","sim":{"duration_s":-Infinity}}}', "base.sim.duration_s"),
    (b'{"name":"s","base":{"kind":"recovery"},"points":[{"sim.duration_s":1e999}]}', "points.0.sim.duration_s"),
    (b'{"name":"s","base":{"kind":"recovery"},"grid":{"sim.duration_s":[1,1e999]}}', "grid.sim.duration_s.1"),
])
def test_the_body_parser_states_the_range_of_a_non_finite_number(raw, field):
    with pytest.raises(BodyError) as e:
        parse_json(raw)
    assert e.value.errors[0]["field"] == field
    assert "finite" in e.value.errors[0]["message"] and "allowed: 0.5 <= duration_s <= 120 (in s)" \
        in e.value.errors[0]["message"], e.value.errors


def test_a_non_finite_number_outside_any_spec_keeps_its_message():
    with pytest.raises(BodyError) as e:
        parse_json(b'{"x": [1e999]}')
    assert e.value.errors == [{"field": "x.0", "message": "1e999 is out of range (a finite number is required)"}]


def test_a_study_states_its_own_ranges_and_its_points():
    from app.studies.spec import expand

    with pytest.raises(SpecError) as e:
        expand({"name": "", "base": {"kind": "recovery"}, "points": [{}], "report": {"metrics": []}})
    got = {x["field"]: x["message"] for x in e.value.errors}
    assert "allowed: 1 to 200 characters" in got["name"] and "allowed: 1 to 32 items" in got["report.metrics"]
    with pytest.raises(SpecError) as e:
        expand({"name": "s", "base": {"kind": "recovery"}, "points": [{"search.population": 2}],
                "report": {"metrics": ["best.fitness"]}})
    assert e.value.errors[0]["field"] == "points[0].search.population"
    assert "allowed: 4 <= population <= 1000" in e.value.errors[0]["message"]


def test_reproduce_options_state_their_range(capsys):
    from app.cli.local import _experiment_command

    class Params(BaseModel):
        population: int = Field(30, ge=4, le=1000, description="DE population (paper: 30)")
        period_s: float = Field(0.6, gt=0.0, le=5.0, description="gait period")

    def run(params, log):
        raise AssertionError("a bad option must stop before the experiment runs")

    command = _experiment_command(Experiment("x", "test", Params, run))
    with pytest.raises(typer.Exit) as e:
        command(population=2, period_s=9.0, write_docs=False)
    assert e.value.exit_code == 2
    out = " ".join(capsys.readouterr().err.split())
    assert "--population: Input should be greater than or equal to 4; allowed: 4 <= population <= 1000" in out
    assert "--period-s: Input should be less than or equal to 5; allowed: 0 < period_s <= 5 (in s)" in out


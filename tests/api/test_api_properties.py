"""Property test (issue 15): bodies generated from each kind's own JSON schema, then
mutated the way hostile or careless clients do (wrong types, non-finite and extreme
numbers, deep nesting, duplicate keys, unknown fields, odd unicode), sent as raw bytes to
the real app on a real SQLite store. Whatever arrives: never a 5xx, every 4xx names a
field, no row for a rejected spec, and an accepted body is one the schema allows.

The generator reads the schema the API publishes (types, bounds, enums, $refs, anyOf,
prefixItems), so a kind added to the registry is covered without touching this file."""

from __future__ import annotations

import json
import math
import os

import jsonschema_rs
import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings, strategies as st
from service_support import deployment, migrated
from sqlalchemy import func, select

from app.api import create_app
from app.jobs.registry import KINDS
from app.store.db import session_scope
from app.store.models import Job

EXAMPLES = int(os.environ.get("GAITMEND_PROPERTY_EXAMPLES", "150"))  # per kind; ~60 s for all kinds


class Raw:
    """A token written into the body as it is (NaN, 1e999, a 400-digit integer...)."""

    def __init__(self, text: str):
        self.text = text


class Dup(dict):
    """An object written with one of its keys twice (the first copy holds `first`)."""

    def __init__(self, items, key, first):
        super().__init__(items)
        self.key, self.first = key, first


def dump(v) -> str:
    if isinstance(v, Raw):
        return v.text
    if isinstance(v, Dup):
        pairs = [(v.key, v.first)] + list(v.items())
        return "{" + ",".join(f"{json.dumps(k)}:{dump(x)}" for k, x in pairs) + "}"
    if isinstance(v, dict):
        return "{" + ",".join(f"{json.dumps(k)}:{dump(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ",".join(dump(x) for x in v) + "]"
    return json.dumps(v)


# -- values the schema allows ------------------------------------------------------------------

def _resolve(schema: dict, root: dict) -> dict:
    while "$ref" in schema:
        schema = root["$defs"][schema["$ref"].rsplit("/", 1)[1]]
    return schema


def from_schema(schema: dict, root: dict, depth: int = 0) -> st.SearchStrategy:
    schema = _resolve(schema, root)
    if "const" in schema:
        return st.just(schema["const"])
    if "enum" in schema:
        return st.sampled_from(schema["enum"])
    for key in ("anyOf", "oneOf"):
        if key in schema:
            return st.one_of([from_schema(s, root, depth) for s in schema[key]])
    t = schema.get("type")
    if t == "integer":
        lo = schema.get("minimum", schema.get("exclusiveMinimum", -11) + 1)
        return st.integers(int(lo), int(schema.get("maximum", schema.get("exclusiveMaximum", 10**6 + 1) - 1)))
    if t == "number":
        lo = schema.get("minimum", schema.get("exclusiveMinimum", -1e3))
        hi = schema.get("maximum", schema.get("exclusiveMaximum", 1e3))
        return st.floats(lo, hi, exclude_min="exclusiveMinimum" in schema, exclude_max="exclusiveMaximum" in schema,
                         allow_nan=False, allow_infinity=False) if lo < hi else st.just(lo)
    if t == "boolean":
        return st.booleans()
    if t == "null":
        return st.none()
    if t == "string":
        return st.text(max_size=schema.get("maxLength", 12), min_size=schema.get("minLength", 0))
    if t == "array":
        if "prefixItems" in schema:
            return st.tuples(*(from_schema(s, root, depth + 1) for s in schema["prefixItems"])).map(list)
        items = schema.get("items", {})
        lo = schema.get("minItems", 0)
        return st.lists(from_schema(items, root, depth + 1), min_size=lo,
                        max_size=max(lo, min(schema.get("maxItems", 4), 4)))
    if t == "object" or "properties" in schema:
        props = schema.get("properties", {})
        required = set(schema.get("required", ())) | ({"kind"} if "kind" in props else set())
        if depth > 4:
            return st.just({})
        return st.fixed_dictionaries(
            {k: from_schema(props[k], root, depth + 1) for k in props if k in required},
            optional={k: from_schema(props[k], root, depth + 1) for k in props if k not in required})
    return st.none()


# -- mutations -----------------------------------------------------------------------------------

BAD_NUMBERS = ["NaN", "Infinity", "-Infinity", "1e999", "-1e999", "1e308", "-1e308", "1e-320", "4.9e-324",
               "9" * 400, "-" + "9" * 30, "18446744073709551616", "1" + "0" * 25 + ".5", "0.0" + "0" * 300 + "1"]
WEIRD_TEXT = st.text(alphabet=st.characters(codec="utf-8"), max_size=20) | st.sampled_from(
    ["", " ", "\u0000", "\u202e", "é", "😀", "recovery\u0000", "../../etc/passwd", "a" * 300])
WRONG_TYPES = st.sampled_from(['"30"', '"4.0"', "4.0", "4.5", "true", "false", "null", "[]", "{}", "[1.0]", '["1"]',
                               "[true]", '"1e3"', '"nan"', '"Infinity"', '{"a": 1}'])


def paths(v, prefix=()):
    yield prefix
    if isinstance(v, dict):
        for k, x in v.items():
            yield from paths(x, (*prefix, k))
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from paths(x, (*prefix, i))


def replace(v, path, new):
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(v, dict):
        out = dict(v)
    else:
        out = list(v)
    out[head] = replace(v[head], rest, new)
    return out


@st.composite
def mutated(draw, base):
    choices = list(paths(base))
    kind = draw(st.sampled_from(["number", "type", "type", "nest", "dup", "unknown", "text", "list", "none"]))
    leaves = [p for p in choices if p and not isinstance(_at(base, p), (dict, list, Raw))]
    path = draw(st.sampled_from(leaves if leaves and kind in ("number", "type", "text") else choices))
    if kind == "number":
        new = Raw(draw(st.sampled_from(BAD_NUMBERS)))
    elif kind == "type":
        new = Raw(draw(WRONG_TYPES))
    elif kind == "nest":
        n = draw(st.integers(2, 3000))
        new = Raw("[" * n + "1" + "]" * n)
    elif kind == "text":
        new = draw(WEIRD_TEXT)
    elif kind == "list":
        new = [draw(st.integers(-10**6, 10**6)) for _ in range(draw(st.integers(0, 2000)))]
    elif kind == "none":
        new = None
    else:
        objects = [p for p in choices if isinstance(_at(base, p), dict)]
        if not objects:  # an earlier mutation replaced the whole body
            return replace(base, path, Raw(draw(WRONG_TYPES)))
        target = draw(st.sampled_from(objects))
        obj = _at(base, target)
        if kind == "unknown" or not obj:
            new_obj = dict(obj) | {draw(WEIRD_TEXT | st.just("colour")): 1}
        else:
            key = draw(st.sampled_from(sorted(obj)))
            new_obj = Dup(obj, key, draw(st.sampled_from([Raw('"tipping"'), Raw("1"), Raw("null"), obj[key]])))
        return replace(base, target, new_obj)
    return replace(base, path, new)


def _at(v, path):
    for p in path:
        v = v[p]
    return v


# -- the property ----------------------------------------------------------------------------------

COUNTS = {"requests": 0, "5xx": 0, "4xx": 0, "accepted": 0, "rows_from_rejected": 0}


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    # Limits wide enough that generated valid specs reach the store, not the quota.
    s = migrated(deployment(tmp_path_factory.mktemp("prop"), max_queued_per_owner=100000,
                            max_evaluations_per_job=10**9))
    yield s, TestClient(create_app(s))
    print(f"\nproperty test: {COUNTS['requests']} requests, {COUNTS['5xx']} 5xx, {COUNTS['4xx']} 4xx, "
          f"{COUNTS['accepted']} accepted, {COUNTS['rows_from_rejected']} rows written by rejected specs")


def _rows(s) -> int:
    with session_scope(s.db_url, readonly=True) as sess:
        return sess.scalar(select(func.count()).select_from(Job))


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_generated_and_mutated_specs(service, kind):
    s, client = service
    from app.api.schemas import spec_json_schema  # noqa: F401  (the document the API publishes)

    schema = KINDS[kind].Spec.model_json_schema()
    validator = jsonschema_rs.validator_for(schema)
    valid = from_schema(schema, schema)

    @given(body=valid.flatmap(lambda b: st.one_of(st.just(b), mutated(b), mutated(b).flatmap(mutated))))
    @settings(max_examples=EXAMPLES, deadline=None, database=None, derandomize=True,
              suppress_health_check=list(HealthCheck))
    def check(body):
        raw = dump(body).encode("utf-8", "surrogatepass")
        before = _rows(s)
        r = client.post("/api/jobs", content=raw, headers={"content-type": "application/json"})
        COUNTS["requests"] += 1
        assert r.status_code < 500, (raw[:300], r.status_code, r.text[:500])
        after = _rows(s)
        if r.status_code >= 400:
            COUNTS["4xx"] += 1
            if after != before:
                COUNTS["rows_from_rejected"] += 1
            errors = r.json()["errors"]
            assert errors and all(e["field"] for e in errors), (raw[:300], r.text[:500])
            assert after == before, raw[:300]
        else:
            COUNTS["accepted"] += 1
            assert r.status_code == 201 and after == before + 1
            sent = json.loads(raw)
            assert validator.is_valid(sent), (raw[:300], "accepted a body its own schema refuses")

    check()


def _unbounded(s: dict, root: dict, path: str, out: list) -> None:
    s = _resolve(s, root)
    for key in ("anyOf", "oneOf", "allOf"):
        for sub in s.get(key, []):
            _unbounded(sub, root, path, out)
    if "enum" in s or "const" in s:
        return
    t = s.get("type")
    if t in ("number", "integer"):
        if not ({"minimum", "exclusiveMinimum"} & set(s) and {"maximum", "exclusiveMaximum"} & set(s)):
            out.append(f"{path}: a number needs both bounds")
    elif t == "string" and "maxLength" not in s:
        out.append(f"{path}: a string needs maxLength or an enum")
    elif t == "array":
        if "maxItems" not in s:
            out.append(f"{path}: a list needs maxItems")
        for i, sub in enumerate(s.get("prefixItems", [])):
            _unbounded(sub, root, f"{path}.{i}", out)
        if isinstance(s.get("items"), dict):
            _unbounded(s["items"], root, f"{path}.*", out)
    elif t == "object" or "properties" in s:
        for k, sub in s.get("properties", {}).items():
            _unbounded(sub, root, f"{path}.{k}".lstrip("."), out)
        extra = s.get("additionalProperties")
        if isinstance(extra, dict):
            if "maxProperties" not in s and "propertyNames" not in s:
                out.append(f"{path}: a mapping needs bounded keys")
            _unbounded(extra, root, f"{path}.*", out)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_number_string_and_list_of_a_spec_is_bounded(kind):
    """Issue 15: physical bounds on every number and list length, stated in the schema the
    API publishes (so clients and the property test above see them)."""
    schema = KINDS[kind].Spec.model_json_schema()
    out: list[str] = []
    _unbounded(schema, schema, "", out)
    assert out == [], out

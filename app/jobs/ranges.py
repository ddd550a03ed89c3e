"""The allowed range of a field, for error messages.

pydantic says which bound a value broke ("Input should be greater than or equal to 4");
the project's rule is that a bad value's error names the field and its whole allowed range
("...; allowed: 4 <= population <= 1000"), with the unit where one is known. The range is
read from the model's JSON schema (minimum / maximum / exclusiveMinimum / exclusiveMaximum,
minItems / maxItems ...), the same schema the dashboard's form is built from, so the two
never disagree. One place applies it to every pydantic error: ``SpecError.from_validation``
(app/jobs/base.py), which every kind's spec, studies and `gaitmend reproduce` options go
through, and so the API, the CLI and the dashboard's form. Besides: the request body parser
(app/api/body.py) for its non-finite numbers, the API's query and header parameters
(app/api/errors.py, from the OpenAPI schema).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Sequence
from typing import Any

from pydantic import BaseModel

# pydantic error types that are about a value's range (or a list's, a string's, a mapping's
# length); finite_number is the strict models' allow_inf_nan=False.
RANGE_TYPES = frozenset({"greater_than", "greater_than_equal", "less_than", "less_than_equal", "finite_number",
                         "too_short", "too_long", "string_too_short", "string_too_long"})
LENGTH_TYPES = frozenset({"too_short", "too_long", "string_too_short", "string_too_long"})

# Units as a description states them: "(deg/s)", "in m", "0.25 m", "seconds".
_UNIT_WORDS = {"seconds": "s", "second": "s", "milliseconds": "ms", "metres": "m", "meters": "m", "metre": "m",
               "meter": "m", "degrees": "deg", "radians": "rad", "hertz": "Hz", "newtons": "N", "percent": "%"}
_UNITS = ("deg/s", "rad/s", "m/s", "m/s^2", "deg", "rad", "ms", "mm", "cm", "m", "s", "Hz", "kg", "Nm", "N", "W",
          "J", "%")
_UNIT = "|".join(re.escape(u) for u in sorted(_UNITS, key=len, reverse=True))
_DESCRIPTION_UNIT = [
    re.compile(rf"\(\s*({_UNIT})\s*\)"),                     # "directions (deg)"
    re.compile(rf"\bin ({_UNIT})(?![\w/^])"),                 # "height in m"
    re.compile(rf"\d\s*({_UNIT})(?![\w/^])"),                 # "(Table 1: 0.25 m)"
    re.compile(r"\b(" + "|".join(_UNIT_WORDS) + r")\b"),      # "simulated seconds per run"
]
# The project's naming convention: a quantity's name ends with its unit (duration_s,
# speed_m_s, crab_angle_deg, density_per_m2). Longest suffix first.
_NAME_UNITS = (("_per_m2", "per m^2"), ("_deg_s", "in deg/s"), ("_rad_s", "in rad/s"), ("_m_s", "in m/s"),
               ("_deg", "in deg"), ("_rad", "in rad"), ("_ms", "in ms"), ("_hz", "in Hz"), ("_kg", "in kg"),
               ("_m", "in m"), ("_s", "in s"))


def allowed(model: type[BaseModel] | None, loc: Sequence[str | int], error_type: str | None = None) -> str | None:
    """The allowed range of the field at pydantic ``loc`` in ``model``, in words
    ("4 <= population <= 1000", "1 to 6 items", "0.5 <= duration_s <= 120 (in s)"), or None
    when the schema states none. ``error_type`` picks a length (too_short, too_long ...) or
    a value range (the rest)."""
    found = _field(model, loc)
    return None if found is None else _words(*found, error_type or "")


def allowed_in_schema(schema: dict[str, Any], loc: Sequence[str | int], error_type: str = "",
                      name: str | None = None) -> str | None:
    """As ``allowed``, on a JSON schema (``name``: what to call the value when ``loc`` is empty)."""
    found = _Walker(schema.get("$defs", {})).walk(schema, tuple(loc), name or "value", None)
    return None if found is None else _words(*found, error_type)


def explain(message: str, text: str | None) -> str:
    """``message`` with the allowed range appended (unchanged when there is none, or when it
    already states one)."""
    if not text or "allowed:" in message:
        return message
    return f"{message}; allowed: {text}"


def explain_error(model: type[BaseModel] | None, error: dict[str, Any], message: str | None = None) -> str:
    """The message of one pydantic error (``ValidationError.errors()`` item), with the field's
    allowed range when it is a range error: a pydantic one, or a validator's own error about
    a number outside the range the field's schema states (e.g. a cap checked in code)."""
    msg = error["msg"] if message is None else message
    etype, loc = error.get("type"), error.get("loc", ())
    if etype in RANGE_TYPES:
        return explain(msg, allowed(model, loc, etype))
    value = error.get("input")
    if isinstance(value, (int, float)) and not isinstance(value, bool) and (found := _field(model, loc)) is not None:
        node = found[0]
        if ("minimum" in node and value < node["minimum"] or "maximum" in node and value > node["maximum"]
                or "exclusiveMinimum" in node and value <= node["exclusiveMinimum"]
                or "exclusiveMaximum" in node and value >= node["exclusiveMaximum"]):
            return explain(msg, _words(*found, ""))
    return msg


@functools.cache
def _schema(model: type[BaseModel]) -> dict[str, Any] | None:
    """The model's JSON schema, once per model."""
    try:
        return model.model_json_schema()
    except Exception:  # a type JSON schema cannot express: no range to state
        return None


def _field(model: type[BaseModel] | None, loc: Sequence[str | int]):
    if model is None:
        return None
    try:
        return _field_at(model, tuple(loc))
    except TypeError:  # an unhashable loc part: no pydantic loc has one
        return None


@functools.lru_cache(maxsize=4096)
def _field_at(model: type[BaseModel], loc: tuple):
    """(schema node, name, description) of the field at ``loc``, or None."""
    schema = _schema(model)
    return None if schema is None else _Walker(schema.get("$defs", {})).walk(schema, loc, "value", None)


def _words(node: dict[str, Any], field: str, description: str | None, error_type: str) -> str | None:
    if error_type in LENGTH_TYPES:
        return _length_range(node)
    return _value_range(node, field, _unit(description, field), error_type == "finite_number")


# -- the schema walk ---------------------------------------------------------------------------

class _Walker:
    def __init__(self, defs: dict[str, Any]):
        self.defs = defs

    def deref(self, node: Any) -> dict[str, Any]:
        if not isinstance(node, dict):
            return {}
        seen = 0
        while "$ref" in node and seen < 64:
            target = self.defs.get(str(node["$ref"]).rsplit("/", 1)[-1], {})
            node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}  # siblings of a $ref win
            seen += 1
        return node

    def options(self, node: dict[str, Any]) -> list[dict[str, Any]]:
        opts = node.get("anyOf") or node.get("oneOf") or []
        return [o for o in (self.deref(x) for x in opts) if o.get("type") != "null"]

    def walk(self, node: Any, loc: tuple, field: str, description: str | None):
        """(schema node at ``loc``, the field's name for the range, the description of the
        nearest named field) or None when ``loc`` does not lead anywhere in the schema."""
        node = self.deref(node)
        if "anyOf" in node or "oneOf" in node:
            return self._union(node, loc, field, description)
        if not loc:
            return node, field, description
        seg, rest = loc[0], loc[1:]
        props = node.get("properties")
        if isinstance(props, dict) or node.get("type") == "object":
            key = str(seg)
            if isinstance(props, dict) and key in props:
                sub = props[key]
                return self.walk(sub, rest, key, sub.get("description") if isinstance(sub, dict) else None)
            extra = node.get("additionalProperties")
            if isinstance(extra, dict):
                return self.walk(extra, rest, f"{field}[{key}]", description)
            return None
        if node.get("type") == "array":
            if isinstance(seg, bool) or not (isinstance(seg, int) or (isinstance(seg, str) and seg.isdigit())):
                return None
            i = int(seg)
            prefix = node.get("prefixItems")
            sub = prefix[i] if isinstance(prefix, list) and i < len(prefix) else node.get("items")
            return self.walk(sub, rest, f"{field}[{i}]", description) if isinstance(sub, dict) else None
        return None

    def _union(self, node: dict[str, Any], loc: tuple, field: str, description: str | None):
        siblings = {k: v for k, v in node.items() if k not in ("anyOf", "oneOf", "discriminator")}
        description = siblings.get("description", description)
        real = self.options(node)
        if not loc:
            # a nullable field: its one real option, with what the field itself states
            return (real[0] | siblings, field, description) if len(real) == 1 else None
        mapping = (node.get("discriminator") or {}).get("mapping") or {}
        if isinstance(loc[0], str) and loc[0] in mapping:  # a tagged union: the tag picks the member
            return self.walk({"$ref": mapping[loc[0]]}, loc[1:], field, description)
        for opt in real:
            if (found := self.walk(opt, loc, field, description)) is not None:
                return found
        if isinstance(loc[0], str):  # an untagged union names the member it tried ("int", "Model")
            for opt in real:
                if (found := self.walk(opt, loc[1:], field, description)) is not None:
                    return found
        return None


# -- words ----------------------------------------------------------------------------------------

def _num(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e16:
        return str(int(v))
    return repr(v) if isinstance(v, float) else str(v)


def _value_range(node: dict[str, Any], field: str, unit: str | None, finite: bool) -> str | None:
    lo = ("<=", node["minimum"]) if "minimum" in node else ("<", node["exclusiveMinimum"]) \
        if "exclusiveMinimum" in node else None
    hi = ("<=", node["maximum"]) if "maximum" in node else ("<", node["exclusiveMaximum"]) \
        if "exclusiveMaximum" in node else None
    if lo and hi:
        text = f"{_num(lo[1])} {lo[0]} {field} {hi[0]} {_num(hi[1])}"
    elif lo:
        text = f"{field} {'>=' if lo[0] == '<=' else '>'} {_num(lo[1])}"
    elif hi:
        text = f"{field} {hi[0]} {_num(hi[1])}"
    elif finite:
        text = "any finite number"
    else:
        return None
    return f"{text} ({unit})" if unit else text


def _length_range(node: dict[str, Any]) -> str | None:
    kind = node.get("type")
    if kind == "string":
        lo, hi, noun = node.get("minLength"), node.get("maxLength"), "character"
    elif kind == "object":
        lo, hi, noun = node.get("minProperties"), node.get("maxProperties"), "entry"
    else:
        lo, hi, noun = node.get("minItems"), node.get("maxItems"), "item"

    def n(count: int) -> str:
        plural = "entries" if noun == "entry" else noun + "s"
        return f"{count} {noun if count == 1 else plural}"

    lo = lo or 0
    if hi is None:
        return f"at least {n(lo)}" if lo else None
    if lo == hi:
        return f"exactly {n(hi)}"
    if not lo:
        return f"at most {n(hi)}"
    return f"{lo} to {n(hi)}"


def _unit(description: str | None, field: str) -> str | None:
    """The unit the field's description names, else the one its name ends with, as words
    for after the range ("in s", "per m^2")."""
    if description:
        for pattern in _DESCRIPTION_UNIT:
            if m := pattern.search(description):
                return f"in {_UNIT_WORDS.get(m.group(1), m.group(1))}"
    name = field.split("[", 1)[0]
    for suffix, words in _NAME_UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return words
    return None

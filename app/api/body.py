"""The request body parser: bounded before it parses deeply, strict after.

`json.loads` recurses once per nesting level (a body nested ~1000 deep is a RecursionError)
and turns a 5000-digit integer into a ValueError; it accepts NaN and Infinity, which are
not JSON, and lets the last of two equal keys win silently. Here the nesting depth is
counted by a flat scan first, then every number, key and string is checked with the path
of the field it sits in, so a bad body is a 4xx that names its field, never a 5xx.

Choices: a UTF-8 byte-order mark is refused (RFC 8259 says senders must not add one; a
body either is plain UTF-8 JSON or it is refused, so the same bytes mean the same thing to
every client). Integers may have up to MAX_INT_DIGITS digits; specs' own bounds are far
tighter, this only keeps the parser's cost linear and its errors clean.
"""

from __future__ import annotations

import json
import math
import re
import sys

from app.jobs.ranges import allowed, explain

MAX_DEPTH = 32
MAX_INT_DIGITS = 20  # beyond int64; every integer a spec takes is far smaller
MAX_NUMBER_CHARS = 64

# Strings (with their escapes) are skipped so brackets inside them do not count.
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKET = re.compile(r"[\[\]{}]")


class BodyError(ValueError):
    """``errors``: [{"field", "message"}], the field as a dotted path ("search.population")."""

    def __init__(self, errors: list[dict[str, str]]):
        self.errors = errors
        super().__init__("; ".join(f"{e['field']}: {e['message']}" for e in errors))


class _Bad:
    """A value the parser hooks could not accept; reported with its path afterwards.
    ``finite``: a non-finite number, whose error states the field's allowed range."""

    def __init__(self, message: str, finite: bool = False):
        self.message = message
        self.finite = finite


class _Pairs(dict):
    duplicates: list[str]


def _pairs(pairs):
    d = _Pairs(pairs)
    d.duplicates = []
    if len(d) != len(pairs):
        seen: set[str] = set()
        for k, _ in pairs:
            if k in seen and k not in d.duplicates:
                d.duplicates.append(k)
            seen.add(k)
    return d


def _int(s: str):
    digits = len(s.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        return _Bad(f"integer with {digits} digits; at most {MAX_INT_DIGITS} are accepted")
    return int(s)


def _float(s: str):
    if len(s) > MAX_NUMBER_CHARS:
        return _Bad(f"number written with {len(s)} characters; at most {MAX_NUMBER_CHARS} are accepted")
    v = float(s)
    if not math.isfinite(v):
        return _Bad(f"{s} is out of range (a finite number is required)", finite=True)
    if v != 0.0 and abs(v) < sys.float_info.min:  # subnormal: no physical quantity in a spec is this small
        return _Bad(f"{s} is too small to be a physical quantity (write 0, or at least {sys.float_info.min:.1e})")
    return v


def _constant(s: str):
    return _Bad(f"{s} is not JSON (numbers must be finite)", finite=True)


def _depth(text: str) -> int:
    depth = deepest = 0
    for m in _BRACKET.finditer(_STRING.sub("", text)):
        depth += 1 if m.group() in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _path(parts: tuple) -> str:
    return ".".join(str(p) for p in parts) or "body"


def _has_surrogate(s: str) -> bool:
    return any("\ud800" <= c <= "\udfff" for c in s)


def _spec_range(doc, path: tuple) -> str | None:
    """The allowed range of the spec field at ``path`` in a job spec, or in a study (its
    ``base``, and the overrides of its ``points`` and ``grid``: dotted paths into the base);
    None for any other document."""
    from app.jobs.registry import KINDS  # here: the kinds load only for such an error

    def spec_of(d):
        kind = KINDS.get(d.get("kind")) if isinstance(d, dict) and isinstance(d.get("kind"), str) else None
        return kind.Spec if kind is not None else None

    if (spec := spec_of(doc)) is not None:
        return allowed(spec, path, "finite_number")
    if (spec := spec_of(doc.get("base") if isinstance(doc, dict) else None)) is None or not path:
        return None
    if path[0] == "base":
        loc = path[1:]
    elif path[0] == "points" and len(path) >= 3:
        loc = (*str(path[2]).split("."), *path[3:])
    elif path[0] == "grid" and len(path) >= 3:
        loc = (*str(path[1]).split("."), *path[3:])
    else:
        return None
    return allowed(spec, loc, "finite_number")


def _check(value) -> list[dict[str, str]]:
    """Every rejected value in the parsed tree, with its path (iterative: no recursion); a
    non-finite number's message states the allowed range of its field."""
    errors, stack = [], [((), value)]
    while stack:
        path, v = stack.pop()
        if isinstance(v, _Bad):
            errors.append({"field": _path(path),
                           "message": explain(v.message, _spec_range(value, path)) if v.finite else v.message})
        elif isinstance(v, str):
            if _has_surrogate(v):
                errors.append({"field": _path(path), "message": "a string with an unpaired surrogate is not text"})
        elif isinstance(v, dict):
            for k in getattr(v, "duplicates", []):
                errors.append({"field": _path((*path, k)), "message": "duplicate key (each key may appear once)"})
            for k, item in v.items():
                if _has_surrogate(k):
                    errors.append({"field": _path(path), "message": "a key with an unpaired surrogate is not text"})
                    continue
                stack.append(((*path, k), item))
        elif isinstance(v, list):
            stack.extend(((*path, i), item) for i, item in enumerate(v))
    return sorted(errors, key=lambda e: e["field"])


def parse_json(raw: bytes, max_depth: int = MAX_DEPTH):
    """The JSON value of a request body, or BodyError naming what is wrong and where."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raise BodyError([{"field": "body", "message": "starts with a UTF-8 byte-order mark; send UTF-8 JSON "
                                                      "without one"}])
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise BodyError([{"field": "body", "message": f"not UTF-8: {e.reason} at byte {e.start}"}]) from None
    if (depth := _depth(text)) > max_depth:
        raise BodyError([{"field": "body", "message": f"nested {depth} levels deep; at most {max_depth} "
                                                      "are accepted"}])
    try:
        value = json.loads(text, object_pairs_hook=_pairs, parse_int=_int, parse_float=_float,
                           parse_constant=_constant)
    except json.JSONDecodeError as e:
        raise BodyError([{"field": "body", "message": f"not JSON: {e.msg} at line {e.lineno} column {e.colno}"}]) \
            from None
    except RecursionError:  # the scan above bounds depth; kept so no input can escape as a 500
        raise BodyError([{"field": "body", "message": "nested too deeply"}]) from None
    if errors := _check(value):
        raise BodyError(errors)
    return _plain(value)


def _plain(value):
    """Plain dicts (the duplicate bookkeeping dropped), iteratively."""
    if not isinstance(value, (dict, list)):
        return value
    root = dict(value) if isinstance(value, dict) else list(value)
    stack = [root]
    while stack:
        node = stack.pop()
        items = node.items() if isinstance(node, dict) else enumerate(node)
        for k, v in list(items):
            if isinstance(v, (dict, list)):
                node[k] = dict(v) if isinstance(v, dict) else list(v)
                stack.append(node[k])
    return root

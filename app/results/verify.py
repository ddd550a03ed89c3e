"""`gaitmend verify` and ``Bundle.verify``: re-run a bundle's job here and compare every
number of its result with the bundle's, wall-clock figures excepted."""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
from pathlib import Path
from typing import Any

# Wall-clock figures differ from run to run (any *_s or *_per_s under "timing", and these
# keys anywhere); every other number must be identical.
_CLOCK_KEYS = ("wall_s", "_per_s", "elapsed_s", "created_at")


def _is_clock(key: str) -> bool:
    return key.endswith(_CLOCK_KEYS)


# What "equal within tolerance" means: every number of the fresh result within this relative
# difference of the bundle's (or this absolute one, for numbers near zero): the size of a
# difference in the order of the same floating-point operations (another BLAS, SIMD width or
# compiler) that did not grow. A search that acts on a number differing even in its last bit
# can take another path, after which its numbers differ far beyond this: "different".
REL_TOL = 1e-9
ABS_TOL = 1e-12
OUTCOMES = ("identical", "within_tolerance", "different")


def _walk(a: Any, b: Any, path: str = ""):
    """Every comparison of two results, in order: ("number", path, x, y) for each pair of
    numbers (equal or not), ("other", path, text) for each difference of another sort (a
    key, a length, a text or a flag), wall-clock figures left out."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if _is_clock(str(k)):
                continue
            where = f"{path}.{k}" if path else str(k)
            if k not in a or k not in b:
                yield "other", where, f"{where}: only in the {'bundle' if k in a else 'new run'}"
                continue
            x, y = a[k], b[k]
            if k == "timing" and isinstance(x, dict) and isinstance(y, dict):  # clock times; counts must agree
                x = {n: v for n, v in x.items() if isinstance(v, int)}
                y = {n: v for n, v in y.items() if isinstance(v, int)}
            yield from _walk(x, y, where)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            yield "other", path, f"{path}: {len(a)} items in the bundle, {len(b)} in the new run"
            return
        for i, (x, y) in enumerate(zip(a, b)):
            yield from _walk(x, y, f"{path}.{i}")
    elif _number(a) and _number(b):
        yield "number", path, a, b
    elif not _same_number(a, b):
        yield "other", path, f"{path}: bundle {a!r}, new run {b!r}"


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """The first place where two results differ (wall-clock figures excepted), or None."""
    for item in _walk(a, b, path):
        if item[0] == "other":
            return item[2]
        _, where, x, y = item
        if x != y:
            return f"{where}: bundle {x!r}, new run {y!r}"
    return None


@dataclasses.dataclass(frozen=True)
class Comparison:
    """Every number of a bundle's result against a fresh run's: how many were compared, how
    many differ and by how much at most (relative and absolute, and where), and the first
    difference of any sort; ``outcome`` names which of OUTCOMES it is."""

    numbers: int
    differing: int
    other: int  # differences that are no number's value: a key, a length, a text, a flag
    max_rel: float
    max_abs: float
    where: str | None  # the number with the largest relative difference
    first: str | None
    beyond: int  # differing numbers beyond both tolerances

    @property
    def outcome(self) -> str:
        if self.first is None:
            return "identical"
        return "within_tolerance" if self.other == 0 and self.beyond == 0 else "different"

    def text(self) -> str:
        """What `gaitmend verify` prints."""
        if self.outcome == "identical":
            return (f"identical: same numbers, all {self.numbers:,} of result.json (wall-clock times excepted), "
                    f"bit for bit")
        head = (f"{self.differing:,} of {self.numbers:,} numbers differ"
                + (f", {self.other:,} other difference{'s' if self.other > 1 else ''}" if self.other else "")
                + (f"; the largest relative difference is {self.max_rel:.3g} at {self.where} (absolute "
                   f"{self.max_abs:.3g})" if self.where else ""))
        if self.outcome == "within_tolerance":
            return (f"equal within tolerance: {head}; every number within {REL_TOL:g} relative or {ABS_TOL:g} "
                    f"absolute (floating-point order, not the search's path); first: {self.first}")
        return f"DIFFERENT: {self.first}; {head}"

    def to_json(self) -> dict:
        return {"outcome": self.outcome, "numbers": self.numbers, "differing": self.differing, "other": self.other,
                "beyond_tolerance": self.beyond, "max_rel": self.max_rel, "max_abs": self.max_abs, "where": self.where, "first": self.first,
                "rel_tol": REL_TOL, "abs_tol": ABS_TOL}


def compare(bundle: Any, fresh: Any) -> Comparison:
    """Every number of ``bundle``'s result against ``fresh``'s (``_walk``)."""
    numbers = differing = other = beyond = 0
    max_rel = max_abs = 0.0
    where = first = None
    for item in _walk(bundle, fresh):
        if item[0] == "other":
            other += 1
            first = first or item[2]
            continue
        _, path, x, y = item
        numbers += 1
        if x == y:
            continue
        differing += 1
        first = first or f"{path}: bundle {x!r}, new run {y!r}"
        ab = abs(float(x) - float(y))
        rel = ab / max(abs(float(x)), abs(float(y)))
        beyond += rel > REL_TOL and ab > ABS_TOL
        if where is None or rel > max_rel:
            max_rel, where = rel, path
        max_abs = max(max_abs, ab)
    return Comparison(numbers, differing, other, max_rel, max_abs, where, first, beyond)


def _same_number(a: Any, b: Any) -> bool:
    """Equal, where a number that is not finite is the same as itself (NaN == NaN) and as the
    null a bundle writes in its place (JSON has no NaN or Infinity: app/results/bundle.py)."""
    def unwritable(v: Any) -> bool:
        return v is None or (isinstance(v, float) and not math.isfinite(v))

    if a == b:
        return True
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return unwritable(a) and unwritable(b) and (a is None or b is None)


def rerun(spec: Any, ctx_factory=None) -> dict:
    """The summary of a fresh run of ``spec`` (a parsed spec), as result.json would hold it.
    ``ctx_factory(folder)`` makes the run context (default: no progress, checkpoints in memory)."""
    from app.jobs.base import MemoryContext, dumps
    from app.jobs.registry import get_kind

    with tempfile.TemporaryDirectory() as tmp:
        ctx = (ctx_factory or MemoryContext)(Path(tmp))
        result = get_kind(spec.kind).run(spec, ctx)
    return json.loads(dumps(result.summary))

"""`gaitmend verify` and ``Bundle.verify``: re-run a bundle's job here and compare every
number of its result with the bundle's, wall-clock figures excepted."""

from __future__ import annotations

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


def first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """The first place where two results differ (wall-clock figures excepted), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if _is_clock(str(k)):
                continue
            where = f"{path}.{k}" if path else str(k)
            if k not in a or k not in b:
                return f"{where}: only in the {'bundle' if k in a else 'new run'}"
            x, y = a[k], b[k]
            if k == "timing" and isinstance(x, dict) and isinstance(y, dict):  # clock times; counts must agree
                x = {n: v for n, v in x.items() if isinstance(v, int)}
                y = {n: v for n, v in y.items() if isinstance(v, int)}
            if (d := first_difference(x, y, where)) is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: {len(a)} items in the bundle, {len(b)} in the new run"
        for i, (x, y) in enumerate(zip(a, b)):
            if (d := first_difference(x, y, f"{path}.{i}")) is not None:
                return d
        return None
    if not _same_number(a, b):
        return f"{path}: bundle {a!r}, new run {b!r}"
    return None


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

"""Job kinds by name. A kind is a module with ``Spec`` (pydantic, ``kind`` literal) and
``run(spec, ctx) -> JobResult``; it never sees a database session or a Celery object."""

from __future__ import annotations

import types
from typing import Any

from pydantic import ValidationError

from app.jobs import multigait, recovery
from app.jobs import tipping
from app.jobs.base import SpecError

KINDS: dict[str, types.ModuleType] = {"recovery": recovery, "multigait": multigait, "tipping": tipping}


def get_kind(name: str) -> types.ModuleType:
    if not isinstance(name, str):  # [] or {} are unhashable: a lookup would raise TypeError
        raise SpecError([{"field": "kind", "message": f"must be a string; allowed: {sorted(KINDS)}"}])
    try:
        return KINDS[name]
    except KeyError:
        raise SpecError([{"field": "kind", "message": f"unknown kind {name!r}; allowed: {sorted(KINDS)}"}]) from None


def parse_spec(data: Any):
    """Validate a spec dict; raises SpecError naming every bad field."""
    if not isinstance(data, dict):
        raise SpecError([{"field": "spec", "message": "a job spec must be a JSON object"}])
    if "kind" not in data:
        raise SpecError([{"field": "kind", "message": f"missing; allowed: {sorted(KINDS)}"}])
    kind = get_kind(data["kind"])
    try:
        return kind.Spec.model_validate(data)
    except ValidationError as e:
        raise SpecError.from_validation(e) from None

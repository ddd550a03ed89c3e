"""Job kinds by name: one line per kind. A kind is a package ``app/jobs/<name>/`` whose
``KIND`` obeys the contract in app/jobs/base.py (``Kind``); it never sees a database
session or a Celery object.

``GAITMEND_EXTRA_KINDS`` (comma-separated ``module:attribute``) registers further kinds
without editing app/: the contract tests register a small kind defined in tests/ this way,
and worker subprocesses inherit it through the environment.
"""

from __future__ import annotations

import importlib
import os
from typing import Any

from app.jobs.base import Kind, SpecError, check_kind
from app.jobs.energy import KIND as _energy
from app.jobs.freegait import KIND as _freegait
from app.jobs.multigait import KIND as _multigait
from app.jobs.recovery import KIND as _recovery
from app.jobs.repertoire import KIND as _repertoire
from app.jobs.tipping import KIND as _tipping

KINDS: dict[str, Kind] = {}


def register(kind: Kind) -> Kind:
    """Add a kind (the first of a name stays). Refused with a TypeError naming the member
    when it sets a name the contract (app/jobs/base.py Kind) does not declare, a method
    that cannot be called as the contract's, or lacks a required member."""
    if not isinstance(kind, Kind):
        raise TypeError(f"{kind!r} is not a Kind")
    check_kind(kind)
    return KINDS.setdefault(kind.name, kind)


for _kind in (_recovery, _multigait, _tipping, _freegait, _energy, _repertoire):
    register(_kind)


def _load_extra(spec: str) -> None:
    for item in filter(None, (s.strip() for s in spec.split(","))):
        module, _, attr = item.partition(":")
        kind = getattr(importlib.import_module(module), attr or "KIND")
        if not isinstance(kind, Kind):
            raise TypeError(f"GAITMEND_EXTRA_KINDS: {item} is not a Kind")
        register(kind)


_load_extra(os.environ.get("GAITMEND_EXTRA_KINDS", ""))


def get_kind(name: str) -> Kind:
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
    return get_kind(data["kind"]).Spec.parse(data)


def user_robot_kinds() -> list[str]:
    """The kinds that run on an uploaded robot (``Kind.user_robots``)."""
    return [k.name for k in KINDS.values() if k.user_robots]


def robots() -> dict[str, dict[str, Any]]:
    """Every robot any kind serves: {name: {"description", "kinds": [kind names]}}."""
    out: dict[str, dict[str, Any]] = {}
    for kind in KINDS.values():
        for name, description in kind.robots.items():
            entry = out.setdefault(name, {"description": description, "kinds": []})
            entry["kinds"].append(kind.name)
    return out

"""The built-in studies, gathered from every registered kind (``Kind.builtin_studies``): the
one place outside the kinds' packages that knows which exist. `gaitmend study run NAME`,
`gaitmend reproduce <kind>-study`, /api/studies/builtin and app/cli/study_scaling.py ask here."""

from __future__ import annotations

from typing import Any

from app.jobs.registry import KINDS


def _gather() -> list[tuple[str, str, dict[str, Any]]]:
    """(kind, name, study) in registry order and each kind's own order; a name is unique."""
    out, seen = [], {}
    for kind in KINDS.values():
        for name, study in kind.builtin_studies().items():
            if name in seen:
                raise ValueError(f"built-in study {name!r} is declared by kinds {seen[name]!r} and {kind.name!r}")
            seen[name] = kind.name
            out.append((kind.name, name, study))
    return out


def builtin_studies() -> dict[str, dict[str, Any]]:
    """{name: study spec} over the registry, in registry order and each kind's own order
    (its paper table first). Fresh dicts on every call: a caller may change them."""
    return {name: study for _, name, study in _gather()}


def builtin_study(name: str) -> dict[str, Any] | None:
    """One built-in study's spec, or None when no kind has one of that name."""
    return builtin_studies().get(name)


def kind_studies(kind: str) -> list[str]:
    """The names of ``kind``'s built-in studies, its paper table first ([] for an unknown kind)."""
    k = KINDS.get(kind)
    return list(k.builtin_studies()) if k is not None else []


def listing() -> list[dict[str, str]]:
    """[{"name", "kind", "title"}] for every built-in study, in builtin_studies' order;
    ``title`` is the study's own ``name`` field (what its page shows)."""
    return [{"name": name, "kind": kind, "title": str(study.get("name", name))} for kind, name, study in _gather()]

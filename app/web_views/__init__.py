"""Dashboard views per job kind, until each kind package carries its own ``views``.

A kind's views module has ``views(summary, traces) -> list[panel]`` (see ``kit``),
``headline(summary) -> list[row]`` and ``convergence(spec) -> dict | None`` (what the
history's best/mean columns mean, with units and which way is better)."""

from __future__ import annotations

import importlib
import types


def for_kind(kind: str) -> types.ModuleType | None:
    try:
        from app.jobs.registry import get_kind

        mod = get_kind(kind)
        if hasattr(mod, "views"):
            return mod
    except Exception:
        pass
    try:
        return importlib.import_module(f"app.web_views.{kind}")
    except ImportError:
        return None

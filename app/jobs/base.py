"""What every job kind shares: spec errors, the run context, the result."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from pydantic import ValidationError


class SpecError(ValueError):
    """A spec that must not run. ``errors`` is a list of {"field": dotted path, "message"}."""

    def __init__(self, errors: list[dict[str, str]]):
        self.errors = errors
        super().__init__("; ".join(f"{e['field']}: {e['message']}" for e in errors))

    @classmethod
    def from_validation(cls, exc: ValidationError) -> SpecError:
        out = []
        for e in exc.errors():
            loc = ".".join(str(p) for p in e["loc"] if p not in ("function-after",)) or "spec"
            msg = e["msg"]
            if e["type"] == "extra_forbidden":
                msg = "unknown field"
            if msg.startswith("Value error, "):
                msg = msg[len("Value error, "):]
            out.append({"field": loc, "message": msg})
        return cls(out)


class Cancelled(Exception):
    """Raised inside a search when the job's cancel flag is seen between generations."""


class RunContext(Protocol):
    """All a job kind may touch of the outside world."""

    artifact_dir: Path

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None: ...

    def save_checkpoint(self, state: dict[str, Any]) -> None: ...

    def load_checkpoint(self) -> dict[str, Any] | None: ...

    def is_cancelled(self) -> bool: ...


@dataclasses.dataclass
class JobResult:
    summary: dict[str, Any]  # JSON: what `gaitmend run --json` prints and result.json holds
    history: list[dict[str, float]]  # one row per generation
    traces: dict[str, dict[str, np.ndarray]]  # name -> per-step arrays (best, baseline, ...)
    model_xml: str  # the simulated model, exactly
    evaluations: int
    sim_steps: int


def to_jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist())
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    return x


def dumps(x: Any) -> str:
    return json.dumps(to_jsonable(x), sort_keys=False)

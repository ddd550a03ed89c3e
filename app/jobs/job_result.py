"""What a job returns (``JobResult``: the summary, history, traces and the model exactly as
simulated) and the one way a summary becomes JSON (``to_jsonable``, ``dumps``: NumPy
scalars and arrays to plain numbers and lists). app/jobs/base.py re-exports every name."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import numpy as np


@dataclasses.dataclass
class JobResult:
    summary: dict[str, Any]  # JSON: what `gaitmend run --json` prints and result.json holds
    history: list[dict[str, float]]  # one row per generation
    traces: dict[str, dict[str, np.ndarray]]  # name -> per-step arrays (best, baseline, ...)
    model_xml: str  # the simulated model, exactly
    evaluations: int
    sim_steps: int
    files: dict[str, str] = dataclasses.field(default_factory=dict)  # bundle members the run made (path -> text)


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

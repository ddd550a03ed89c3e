"""All a job kind may touch of the outside world while it runs: ``RunContext`` (progress,
checkpoints, the cancel flag, the artifact folder, uploaded robots), ``Cancelled`` (what a
search raises when it sees the flag) and ``MemoryContext`` (a context with no outside world,
for experiments, benchmarks and `gaitmend run`). The service's database-backed context
(app/service/runner.py) answers the same protocol. app/jobs/base.py re-exports every name."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from app.jobs.spec_base import SpecError


class Cancelled(Exception):
    """Raised inside a search when the job's cancel flag is seen between generations."""


class RunContext(Protocol):
    """All a job kind may touch of the outside world."""

    artifact_dir: Path

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None: ...

    def save_checkpoint(self, state: dict[str, Any]) -> None: ...

    def load_checkpoint(self) -> dict[str, Any] | None: ...

    def is_cancelled(self) -> bool: ...

    def load_robot(self, robot_id: str) -> Any:
        """An uploaded robot by its id (app/robots/legmap.py ``Robot``: the stored, sanitised
        model, its assets and leg map), for a kind with ``user_robots``; SpecError (field
        robot) when there is none of that id."""


class MemoryContext:
    """A run context with no outside world: checkpoints kept in memory, no progress shown,
    never cancelled (experiments, benchmarks, `gaitmend run` wraps it with a progress bar)."""

    def __init__(self, artifact_dir: Path | None = None, robots: Callable[[str], Any] | None = None):
        self.artifact_dir = Path(artifact_dir) if artifact_dir is not None else Path(".")
        self._ckpt: dict[str, Any] | None = None
        self._robots = robots  # robot id -> the uploaded robot (the CLI reads this machine's store)

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        pass

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        self._ckpt = state

    def load_checkpoint(self) -> dict[str, Any] | None:
        return self._ckpt

    def is_cancelled(self) -> bool:
        return False

    def load_robot(self, robot_id: str) -> Any:
        if self._robots is None:
            raise SpecError([{"field": "robot", "message": f"no uploaded robot {robot_id!r}: this run has no robots"}])
        return self._robots(robot_id)

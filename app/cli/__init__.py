"""The ``gaitmend`` command line: local commands (run, bench, reproduce, adapt), server commands
(serve, worker, db, token) and client commands (submit, jobs, fetch, cancel, replay, video), each
group in its own module registering on the one Typer app in ``common``."""

from app.cli import adapt, client, docs_stale, local, robot, server, study, video  # noqa: F401  (each registers its commands)
from app.cli.common import cli, main

__all__ = ["cli", "main"]

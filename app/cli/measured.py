"""A lab's measurement of one trial, typed on stdin (app/adapt/lab.py's line), for
`gaitmend adapt` from files and against a server."""

from __future__ import annotations

import sys

from rich.markup import escape

from app.cli.common import err, fail
from app.jobs.base import SpecError


def read_measurement(what: str):
    """A measurement typed on stdin (app/adapt/lab.py), None at the end of input. A bad line
    is asked again in a terminal and ends the command (exit 2) from a pipe or file."""
    from app.adapt.lab import FIELDS, parse_line

    while True:
        err.print(f"measured ({' '.join(FIELDS)}): ", end="", highlight=False)
        line = sys.stdin.readline()
        if not line:
            return None
        try:
            return parse_line(line)
        except SpecError as e:
            item = e.errors[0]
            if not sys.stdin.isatty():
                fail(f"measurement of trial for {what}: {item['field']}: {item['message']}")
            err.print("[bold red]error:[/] " + escape(f"{item['field']}: {item['message']}; again"), highlight=False)

"""What every `gaitmend` command shares: the Typer app, error output, spec loading."""

from __future__ import annotations

import json
import sys
import zipfile
from importlib import resources
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.markup import escape

from app.jobs.base import SpecError
from app.jobs.registry import parse_spec

cli = typer.Typer(add_completion=False, no_args_is_help=True, help="Gait recovery for damaged legged robots.")
# stderr as stdout: in a terminal rich fits its width; in a pipe or a log a message is one line,
# never broken inside a path or a number (a long data folder used to split "sqlite:///...")
err = Console(stderr=True) if sys.stderr.isatty() else Console(stderr=True, width=100_000, soft_wrap=True)


def out_console() -> Console:
    """stdout. In a terminal, rich fits its width (tables wrap cells, never cut them); in a
    pipe or a log there is no width to fit, so lines are as long as their content."""
    return Console() if sys.stdout.isatty() else Console(width=100_000, soft_wrap=True)


def _version(value: bool) -> None:
    if value:
        from app import __version__

        print(f"gaitmend {__version__}")
        raise typer.Exit()


@cli.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="print the version and exit")):
    """Gait recovery for damaged legged robots."""


def fail(msg: str, code: int = 2) -> None:
    err.print(f"[bold red]error:[/] {escape(msg)}", highlight=False)  # a message's "[...]" is text, not markup
    raise typer.Exit(code)


def fail_fields(errors, where: str = "") -> None:
    """Each ``{"field", "message"}`` error on its own line (after ``where: `` when given), exit 2."""
    for item in errors:
        err.print("[bold red]error:[/] " + escape(f"{where}{item['field']}: {item['message']}"), highlight=False)
    raise typer.Exit(2)


def default_spec_data() -> dict:
    """The spec `gaitmend run` runs when given none (app/jobs/default_spec.json)."""
    return json.loads(resources.files("app.jobs").joinpath("default_spec.json").read_text())


def load_spec(path: Optional[Path]):
    """Parse a spec file (spec JSON, bundle manifest or bundle zip); exit 2 if it is bad."""
    from app.results.bundle import read_spec_file

    from app.api.body import BodyError, parse_json

    try:
        if path is None:
            data = default_spec_data()
        elif path.suffix == ".zip":
            data = read_spec_file(path)
        else:
            # The API's parser: duplicate keys, NaN, a BOM or absurd nesting are errors here too.
            data = parse_json(path.read_bytes())
            if isinstance(data, dict) and "bundle_schema" in data:
                data = data.get("spec")
    except FileNotFoundError:
        fail(f"spec file not found: {path}")
    except IsADirectoryError:
        fail(f"{path} is a folder; give a spec JSON, a bundle's manifest.json or a bundle zip")
    except BodyError as e:
        fail_fields(e.errors, f"{path}: ")
    except (json.JSONDecodeError, zipfile.BadZipFile, KeyError, UnicodeDecodeError) as e:
        fail(f"cannot read spec {path}: {e}")
    try:
        return parse_spec(data)
    except SpecError as e:
        fail_fields(e.errors)


def settings_or_exit():
    from app.core.settings import SettingsError, load_settings

    try:
        return load_settings()
    except SettingsError as e:
        fail(f"bad settings: {e}")


def print_tables(tables, console: Console | None = None) -> None:
    """A kind's summary tables (app/jobs/base.py ``Table``), as rich tables and notes."""
    from rich.table import Table

    con = console or out_console()
    for t in tables:
        rt = Table(title=t["title"])
        for c in t["columns"]:
            rt.add_column(str(c), overflow="fold")
        for row in t["rows"]:
            rt.add_row(*("-" if v is None else str(v) for v in row))
        con.print(rt)
        for note in t.get("notes", []):
            con.print(note, highlight=False)


def main() -> None:
    try:
        cli()
    except KeyboardInterrupt:
        sys.exit(130)

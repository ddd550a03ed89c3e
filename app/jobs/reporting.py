"""Every published number from committed data (issue 28): a generated section of a markdown
page is rendered from the JSON under docs/ that the command in its marker wrote, and
nothing else. In a page a section reads::

    <!-- generated: tipping-cases (gaitmend reproduce tipping --write-docs) -->
    ... text rendered from docs/tipping_cases.json ...
    <!-- /generated -->

A kind declares its sections on its experiments (``Experiment.sections``): a name, the
JSON files the section reads (paths relative to the repository) and a renderer from their
contents to markdown. app/results/docs_gen.py gathers them over the registry and rewrites
or checks every page (``gaitmend docs``, ``gaitmend docs --check``); tests/test_docs_data.py
fails when a page's text differs from its data's."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from app.jobs.ledger import ROOT

MARKER = re.compile(r"<!-- generated: (?P<name>[\w.-]+) \((?P<command>[^)]*)\) -->\n(?P<body>.*?)<!-- /generated -->",
                    re.DOTALL)
# the README's section that gathers every section marked ``readme`` (one line per kind)
SUMMARY = "results-summary"


def pages(root: Path = ROOT) -> list[Path]:
    """The pages whose generated sections are rendered from data: the README and docs/*.md."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


@dataclasses.dataclass(frozen=True)
class Section:
    """A generated section: ``render(data)`` gets the decoded JSON of ``data`` (paths
    relative to the repository, in order; a missing file is None) and returns markdown.
    ``readme``: also a line of README.md's results summary."""

    name: str
    data: tuple[str, ...]
    render: Callable[[list[Any]], str]
    readme: bool = False

    def load(self, root: Path = ROOT) -> list[Any]:
        return [json.loads((root / p).read_text()) if (root / p).exists() else None for p in self.data]

    def text(self, root: Path = ROOT) -> str:
        body = self.render(self.load(root)).strip("\n")
        return body + "\n" if body else ""


def sections_in(text: str) -> list[tuple[str, str, str]]:
    """(name, command, body) of every generated section of a page, in order."""
    return [(m["name"], m["command"], m["body"]) for m in MARKER.finditer(text)]


def marked(name: str, command: str, body: str) -> str:
    """A generated section as a page holds it (``MARKER``): ``body``, its own lines, between
    the opening marker naming the section and its command, and the closing one."""
    lines = body.strip("\n") + "\n" if body.strip("\n") else ""
    return f"<!-- generated: {name} ({command}) -->\n{lines}<!-- /generated -->"


def regenerate(text: str, render: Callable[[str], str]) -> str:
    """``text`` with the body of every generated section replaced by ``render(name)``."""
    return MARKER.sub(lambda m: marked(m["name"], m["command"], render(m["name"])), text)


# -- markdown helpers the renderers share -----------------------------------------------------

def md_table(columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    head = "| " + " | ".join(columns) + " |\n|" + "---|" * len(columns) + "\n"
    return head + "".join("| " + " | ".join(str(c) for c in r) + " |\n" for r in rows)


def num(v: Any, fmt: str = "{:.2f}", none: str = "-") -> str:
    """A number in ``fmt``; None and NaN as ``none``."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return none
    return fmt.format(v)


def yes(v: Any) -> str:
    return "-" if v is None else ("yes" if v else "no")


def missing(path: str, command: str) -> str:
    return f"*No data yet: `{command}` writes {path}.*\n"


def progress_note(data: dict[str, Any], runs: int) -> str:
    """'k of N planned runs' when a ledger is not complete, with the command that continues it."""
    planned = data.get("planned")
    if planned and runs < planned:
        return (f"\n*Partial: {runs} of {planned} planned runs are in the data so far; `{data['command']}` "
                f"continues it (finished runs are skipped).*\n")
    return ""

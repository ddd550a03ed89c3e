"""Which numbers are current (issue 45): a page whose generated sections read a reproduction
ledger (app/jobs/ledger.py) carries, right under its title, a generated banner
``data-age-<page>`` that names every such data file computed by science code that has
changed since, with the files changed and the command that re-runs it; the banner is empty
when all of its data is current. It is rendered from the ledgers' ``code_version`` and
``science_files`` and the science files as they are now, so ``gaitmend docs`` keeps it
current, and ``gaitmend docs --check`` (tests/test_docs_data.py) fails when a data file is
stale and its page does not say so. ``gaitmend docs-stale`` lists the same."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from app.jobs.ledger import ROOT, staleness
from app.jobs.reporting import SUMMARY, Section, pages, sections_in

PREFIX = "data-age-"
COMMAND = "gaitmend docs"


def section_name(page: str) -> str:
    """``data-age-tipping`` for docs/tipping.md, ``data-age-readme`` for README.md."""
    return PREFIX + Path(page).stem.lower()


def is_ledger(data: Any) -> bool:
    return isinstance(data, dict) and bool(data.get("code_version")) and bool(data.get("science"))


def ledger_paths(paths: list[str] | tuple[str, ...], root: Path = ROOT) -> list[str]:
    """The paths among ``paths`` whose committed JSON is a ledger with a code version."""
    out = []
    for p in paths:
        f = root / p
        if p not in out and f.exists() and is_ledger(json.loads(f.read_text())):
            out.append(p)
    return out


def stale(paths: list[str] | tuple[str, ...], root: Path = ROOT,
          loaded: list[Any] | None = None) -> list[tuple[str, dict[str, Any], dict[str, Any]]]:
    """(path, its ledger, its staleness) for each stale ledger among ``paths`` (read under
    ``root``, or given decoded in ``loaded``)."""
    out = []
    for i, p in enumerate(paths):
        f = root / p
        data = loaded[i] if loaded is not None else json.loads(f.read_text()) if f.exists() else None
        if is_ledger(data):
            s = staleness(data)
            if s is not None:
                out.append((p, data, s))
    return out


def render_banner(items: list[tuple[str, dict[str, Any], dict[str, Any]]], readme: bool = False) -> str:
    if not items:
        return ""
    n = len(items)
    if readme:
        names = ", ".join(f"[{Path(p).name}]({p})" for p, _, _ in items)
        return (f"> **Older data.** {n} data file{'s' if n > 1 else ''} behind these figures "
                f"{'were' if n > 1 else 'was'} computed by science code that has changed since "
                f"({names}); each page says which files changed and how to re-run it.\n")
    head = (f"> **Older data.** {n} data file{'s' if n > 1 else ''} on this page "
            f"{'were' if n > 1 else 'was'} computed by science code that has changed since; "
            f"{'their' if n > 1 else 'its'} numbers are those of the recorded code version, not re-run "
            f"on the current code (`gaitmend docs-stale` lists them):\n")
    lines = []
    for p, data, s in items:
        changed = ("which files changed is not recorded" if s["changed"] is None
                   else "changed since: " + ", ".join(_file(c) for c in s["changed"]))
        lines.append(f"> - {Path(p).name} (code {s['recorded']}, now {s['now']}): {changed}; "
                     f"re-run: `{data.get('command', '?')}`\n")
    return head + "".join(lines)


def _file(entry: str) -> str:
    """A changed file as the banner names it; a removed one by its name and folder, since a
    path that no longer exists may not stand in the docs (tests/test_docs.py)."""
    if entry.endswith(" (removed)"):
        path = Path(entry.removesuffix(" (removed)"))
        return f"`{path.name}` (removed from `{path.parent}/`)"
    return f"`{entry}`"


def page_data(root: Path = ROOT, declared: dict[str, Section] | None = None) -> dict[str, list[str]]:
    """{page: the ledger files its generated sections read}, for the pages that have any (the
    README's through its results summary: every section marked ``readme``)."""
    declared = {} if declared is None else declared
    out = {}
    for page in pages(root):
        rel = str(page.relative_to(root))
        paths: list[str] = []
        for name, _, _ in sections_in(page.read_text()):
            secs = ([s for s in declared.values() if s.readme] if name == SUMMARY
                    else [declared[name]] if name in declared else [])
            for s in secs:
                paths.extend(s.data)
        found = ledger_paths(paths, root)
        if found:
            out[rel] = found
    return out


def sections(declared: dict[str, Section], root: Path = ROOT) -> list[Section]:
    """One banner section per page that reads a ledger and carries the banner's marker
    (tests/test_docs_age.py fails for a page that reads one without it)."""
    out = []
    for page, paths in page_data(root, declared).items():
        if f"<!-- generated: {section_name(page)} (" not in (root / page).read_text():
            continue
        readme = page == "README.md"
        out.append(Section(section_name(page), tuple(paths),
                           lambda data, paths=paths, readme=readme: render_banner(stale(paths, loaded=data), readme)))
    return out

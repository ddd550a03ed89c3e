"""The docs hold together: every relative link and image in README.md and docs/*.md points
at a file that exists (an anchor at one of the target's headings, GitHub-style), every
docs page can be reached from the README by following links, the README stays short and
its "Two commands" come first, and every code path (`app/...py`, `app/.../`, tests/,
workers/, scripts/, web/, migrations/) and every `python -m app....` module the docs name
exists, so that a moved module cannot leave a stale path behind. A path or command of an
old commit is written with that commit (`bf4c681:app/stability/cases.py`, `git checkout
bf4c681 && python -m app.stability.cases`) and checked against it.

Each check is a function of a folder laid out like the repository; the tests feed each one
a planted defect as well, so none of them passes by finding nothing to look at."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path
from urllib.parse import unquote

import pytest

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 200

FENCE = re.compile(r"^(```|~~~)")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
CODE_ROOTS = ("app", "tests", "workers", "scripts", "web", "migrations")
# A path starts a word (not after a letter, /, . or -: "/api/web/check" is a route, not web/).
# An optional commit in front (REV:path) checks it against that commit instead.
PATH = re.compile(r"(?<![\w/.:-])(?:([0-9a-f]{7,40}):)?((?:%s)/[\w./<>*-]*)" % "|".join(CODE_ROOTS))
MODULE = re.compile(r"(?:git checkout ([0-9a-f]{7,40}) && )?python3? -m\s+(app(?:\.\w+)*)")


def pages(root: Path) -> list[Path]:
    """README.md and every markdown page under docs/."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def prose_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) outside fenced code blocks, inline code spans removed."""
    out, fenced = [], False
    for n, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append((n, re.sub(r"`[^`]*`", "", line)))
    return out


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: the rendered text, lower case, punctuation dropped,
    spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link renders as its text
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _headings(path: Path) -> list[str]:
    """Headings as written (inline code kept: its text is part of the anchor), code blocks skipped."""
    out, fenced = [], False
    for line in path.read_text().splitlines():
        if FENCE.match(line.lstrip()):
            fenced = not fenced
        elif not fenced and (m := HEADING.match(line)):
            out.append(m.group(2))
    return out


def heading_anchors(path: Path) -> set[str]:
    """The anchors GitHub gives a page's headings (a repeated one gets -1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for h in _headings(path):
        base = slug(h)
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def links(path: Path) -> list[tuple[int, str]]:
    """(line, target) of every relative link and image outside code."""
    out = []
    for n, line in prose_lines(path.read_text()):
        for m in LINK.finditer(line):
            target = m.group(1)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:
                continue
            out.append((n, target))
    return out


def resolve(page: Path, target: str) -> tuple[Path, str]:
    file, _, anchor = target.partition("#")
    return ((page.parent / unquote(file)).resolve() if file else page), unquote(anchor)


def broken_links(root: Path) -> list[str]:
    """Every relative link or image whose file is missing, or whose anchor is no heading of
    its target."""
    bad = []
    for page in pages(root):
        for n, target in links(page):
            dest, anchor = resolve(page, target)
            where = f"{page.relative_to(root)}:{n}: {target}"
            if not dest.exists():
                bad.append(f"{where} (no such file)")
            elif anchor and (dest.suffix != ".md" or anchor not in heading_anchors(dest)):
                bad.append(f"{where} (no heading #{anchor} in {dest.name})")
    return bad


def unreachable(root: Path) -> list[str]:
    """docs pages that following links from README.md never reaches."""
    seen, todo = set(), [(root / "README.md").resolve()]
    while todo:
        page = todo.pop()
        if page in seen or not page.exists() or page.suffix != ".md":
            continue
        seen.add(page)
        todo += [resolve(page, t)[0] for _, t in links(page)]
    return [str(p.relative_to(root)) for p in pages(root)[1:] if p.resolve() not in seen]


def readme_too_long(root: Path, limit: int = README_MAX_LINES) -> str | None:
    n = len((root / "README.md").read_text().splitlines())
    return f"README.md has {n} lines, more than {limit}" if n > limit else None


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=30)


def _git_has(rev: str, paths: list[str]) -> bool | None:
    """Whether any of the paths exists at the commit (False for a commit the history does
    not hold); None when git cannot tell (no git, no repository, a shallow clone that may
    lack the commit)."""
    try:
        shallow = _git("rev-parse", "--is-shallow-repository")
        if shallow.returncode != 0:
            return None
        if _git("cat-file", "-e", f"{rev}^{{commit}}").returncode != 0:
            return None if shallow.stdout.strip() == "true" else False
        return any(_git("cat-file", "-e", f"{rev}:{p}").returncode == 0 for p in paths)
    except (OSError, subprocess.SubprocessError):
        return None


def _exists(root: Path, path: str) -> bool:
    pattern = re.sub(r"<[^>]*>", "*", path.rstrip("/"))
    if "*" in pattern:
        return any(root.glob(pattern))
    return (root / pattern).exists()


def stale_paths(root: Path) -> list[str]:
    """Code paths and `python -m` modules named in the docs (code blocks and inline code
    included) that do not exist; a commit-qualified one must exist at that commit."""
    bad = []
    for page in pages(root):
        text = page.read_text()
        for m in PATH.finditer(text):
            rev, path = m.group(1), m.group(2).rstrip(".,;:")
            n = text.count("\n", 0, m.start()) + 1
            where = f"{page.relative_to(root)}:{n}: {m.group(0).rstrip('.,;:')}"
            if rev:
                if _git_has(rev, [path.rstrip("/")]) is False:
                    bad.append(f"{where} (not in commit {rev})")
            elif not _exists(root, path):
                bad.append(f"{where} (no such path)")
        for m in MODULE.finditer(text):
            rev, module = m.groups()
            base = module.replace(".", "/")
            candidates = [f"{base}.py", f"{base}/__init__.py", f"{base}/__main__.py"]
            n = text.count("\n", 0, m.start()) + 1
            where = f"{page.relative_to(root)}:{n}: python -m {module}"
            if rev:
                if _git_has(rev, candidates) is False:
                    bad.append(f"{where} (not in commit {rev})")
            elif not any((root / c).is_file() for c in candidates):
                bad.append(f"{where} (no such module)")
    return bad


def first_section(root: Path) -> str | None:
    for _, line in prose_lines((root / "README.md").read_text()):
        if line.startswith("## "):
            return line[3:].strip()
    return None


# -- the repository's docs ---------------------------------------------------------------------

def test_every_relative_link_and_image_resolves():
    assert not broken_links(ROOT), "\n".join(broken_links(ROOT))


def test_every_docs_page_is_reachable_from_the_readme():
    assert not unreachable(ROOT), f"not linked from README.md or a page it reaches: {unreachable(ROOT)}"


def test_the_readme_is_short_and_starts_with_the_two_commands():
    assert readme_too_long(ROOT) is None, readme_too_long(ROOT)
    assert first_section(ROOT) == "Two commands"
    readme = (ROOT / "README.md").read_text()
    assert "gaitmend run --out results/" in readme and "\nbash scripts/test.sh\n" in readme
    assert "scripts/test.sh" in (ROOT / ".ci" / "run").read_text(), "CI runs the README's test command"


def test_every_code_path_and_module_in_the_docs_exists():
    assert not stale_paths(ROOT), "\n".join(stale_paths(ROOT))


# -- each check finds a planted defect ---------------------------------------------------------

def _tree(tmp_path: Path, readme: str, docs: dict[str, str]) -> Path:
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text(readme)
    for name, text in docs.items():
        (tmp_path / "docs" / name).write_text(text)
    (tmp_path / "app" / "jobs" / "tipping").mkdir(parents=True)
    (tmp_path / "app" / "jobs" / "tipping" / "bench.py").write_text("")
    return tmp_path


def test_slugs_follow_github():
    assert slug("The kind contract (`app/jobs/base.py`)") == "the-kind-contract-appjobsbasepy"
    assert slug("Measured (2026-12-02, idle 2-core machine, Redis + PostgreSQL)") == \
        "measured-2026-12-02-idle-2-core-machine-redis--postgresql"
    assert slug("Example 1: k_ev (Fig. 8) — `gaitmend reproduce freegait`") == \
        "example-1-k_ev-fig-8--gaitmend-reproduce-freegait"


def test_a_broken_link_image_or_anchor_is_reported(tmp_path):
    root = _tree(tmp_path, "# x\n\n## Two commands\n\n[a](docs/a.md#intro) [b](docs/a.md#gone) "
                           "[c](docs/missing.md) ![d](docs/none.png) [e](https://example.org/x)\n"
                           "```\n[not a link](docs/nowhere.md)\n```\n",
                 {"a.md": "# A\n\n## Intro\n\n```\n# not a heading\n```\n[up](../README.md#two-commands)"
                          " [bad](#not-a-heading)\n"})
    bad = broken_links(root)
    assert any("docs/a.md#gone" in b for b in bad)
    assert any("docs/missing.md" in b for b in bad)
    assert any("docs/none.png" in b for b in bad)
    assert any("#not-a-heading" in b for b in bad), "a '#' line inside a code block is no heading"
    assert len(bad) == 4, bad


def test_an_unreachable_page_is_reported(tmp_path):
    root = _tree(tmp_path, "[a](docs/a.md)\n", {"a.md": "[b](b.md)\n", "b.md": "", "orphan.md": "[a](a.md)\n"})
    assert unreachable(root) == ["docs/orphan.md"]


def test_a_long_readme_is_reported(tmp_path):
    root = _tree(tmp_path, "line\n" * (README_MAX_LINES + 1), {})
    assert readme_too_long(root) and readme_too_long(root, README_MAX_LINES + 1) is None


def test_a_stale_path_or_module_is_reported(tmp_path):
    root = _tree(tmp_path, "`app/jobs/tipping/bench.py` app/jobs/<kind>/ and app/web.py, `app/stability/`.\n"
                           "POST /api/web/check\n",
                 {"a.md": "```\npython -m app.jobs.tipping.bench\npython -m app.studies.scaling\n```\n"})
    bad = stale_paths(root)
    assert any("app/web.py" in b for b in bad) and any("app/stability/" in b for b in bad)
    assert any("app.studies.scaling" in b for b in bad)
    assert len(bad) == 3, bad


def test_a_path_of_an_old_commit_is_checked_against_that_commit(tmp_path):
    if _git_has("bf4c681", ["app/stability/cases.py"]) is None:
        pytest.skip("this checkout has no git history to check against")
    root = _tree(tmp_path, "`bf4c681:app/stability/cases.py`, `bf4c681:app/nowhere.py`, "
                           "`git checkout bf4c681 && python -m app.stability.cases`, "
                           "`git checkout bf4c681 && python -m app.jobs.tipping.bench`\n", {})
    assert stale_paths(root) == ["README.md:1: bf4c681:app/nowhere.py (not in commit bf4c681)",
                                 "README.md:1: python -m app.jobs.tipping.bench (not in commit bf4c681)"]

"""Every published number from committed data (issue 28): each generated section of
README.md and docs/*.md, re-rendered from the JSON under docs/ that its kind's renderer
reads, equals the text on the page; a number edited by hand in a section, or left stale
when its data changed, fails here (shown on a copy of the pages and the data)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from app.jobs.reporting import MARKER, Section, md_table, regenerate, sections_in
from app.results import docs_gen

ROOT = Path(__file__).resolve().parents[1]


def test_every_generated_section_matches_its_data():
    diffs = docs_gen.check()
    assert not diffs, "generated sections differ from their data; run `gaitmend docs`:\n" + "\n\n".join(diffs)


def test_every_marker_names_a_declared_section_and_every_section_is_published():
    declared = docs_gen.all_sections()
    used = [n for names in docs_gen.generated_names().values() for n in names]
    assert set(used) - set(declared) - {docs_gen.SUMMARY} == set()
    summary = {n for n, s in declared.items() if s.readme}  # README's results summary shows these
    assert set(declared) - set(used) - summary == set(), "a section no page shows"
    assert docs_gen.SUMMARY in docs_gen.generated_names()["README.md"]


def test_each_sections_data_is_committed_json_under_docs():
    for name, s in docs_gen.all_sections().items():
        for p in s.data:
            assert p.startswith("docs/") and p.endswith(".json"), (name, p)
            assert (ROOT / p).exists(), f"{name}: {p} is not committed"
            json.loads((ROOT / p).read_text())


@pytest.fixture
def copy(docs_copy):
    return docs_copy


def _first_number_in_a_section(text: str) -> tuple[int, str]:
    for m in MARKER.finditer(text):
        n = re.search(r"(?<![\w.])\d+\.\d+", m["body"])
        if n:
            return m.start("body") + n.start(), n.group(0)
    raise AssertionError("no generated section holds a decimal number")


def _pages_with_generated_numbers() -> list[str]:
    """Every page (README.md included) with a decimal number in one of its generated sections."""
    out = []
    for page, names in docs_gen.generated_names().items():
        body = "".join(m["body"] for m in MARKER.finditer((ROOT / page).read_text()))
        if names and re.search(r"(?<![\w.])\d+\.\d+", body):
            out.append(page)
    return out


def test_the_hand_edit_check_covers_the_readme_and_every_kinds_page():
    pages = _pages_with_generated_numbers()
    assert {"README.md", "docs/tipping.md", "docs/energy.md", "docs/freegait.md", "docs/multigait.md"} <= set(pages)


@pytest.fixture(scope="module")
def rendered(docs_copy_module):
    """Every section rendered once from the copy's data: the edits below touch pages, never
    data, so each check compares the pages against the same renderings (rendering every
    section is the slow part: once here, not four times a page)."""
    root = docs_copy_module
    return root, {n: Section(n, (), lambda data, t=s.text(root): t, s.readme)
                  for n, s in docs_gen.all_sections().items()}


@pytest.mark.parametrize("page", _pages_with_generated_numbers())
def test_a_number_edited_by_hand_is_caught(rendered, page):
    copy, sections = rendered
    assert docs_gen.check(copy, sections) == []
    p = copy / page
    text = p.read_text()
    at, number = _first_number_in_a_section(text)
    edited = number[:-1] + ("1" if number[-1] != "1" else "2")
    p.write_text(text[:at] + edited + text[at + len(number):])
    diffs = docs_gen.check(copy, sections)
    assert len(diffs) == 1 and page in diffs[0] and edited in diffs[0] and number in diffs[0]
    docs_gen.write(copy, sections)  # `gaitmend docs` puts the data's number back
    assert p.read_text() == text and docs_gen.check(copy, sections) == []


def test_stale_text_is_caught_when_the_data_changes(copy):
    path = copy / "docs" / "multigait_paper_s0.json"
    rows = json.loads(path.read_text())
    rows[0]["result"]["initial_mean"] += 1.0
    path.write_text(json.dumps(rows))
    diffs = docs_gen.check(copy)
    assert any("docs/multigait.md" in d for d in diffs)


def test_text_outside_the_markers_is_left_alone():
    s = Section("toy", (), lambda data: md_table(["a"], [[1.5]]))
    page = ("intro 1.0\n<!-- generated: toy (gaitmend reproduce toy) -->\nold 9.9\n<!-- /generated -->\n"
            "outro 2.0\n")
    new = regenerate(page, lambda name: s.text())
    assert new == ("intro 1.0\n<!-- generated: toy (gaitmend reproduce toy) -->\n| a |\n|---|\n| 1.5 |\n"
                   "<!-- /generated -->\noutro 2.0\n")
    assert sections_in(new) == [("toy", "gaitmend reproduce toy", "| a |\n|---|\n| 1.5 |\n")]


def test_an_unknown_section_name_is_an_error(copy):
    p = copy / "docs" / "energy.md"
    p.write_text(p.read_text() + "\n<!-- generated: no-such-section (gaitmend x) -->\n<!-- /generated -->\n")
    with pytest.raises(KeyError, match="no-such-section"):
        docs_gen.check(copy)


def test_a_missing_data_file_says_which_command_writes_it(copy):
    (copy / "docs" / "energy_knots.json").unlink()
    text = docs_gen.renderer(copy)("energy-knots")
    assert "No data yet" in text and "gaitmend reproduce energy-knots --write-docs" in text


def test_the_docs_command_checks_the_pages():
    from typer.testing import CliRunner

    import app.cli.local  # noqa: F401  (registers the commands)
    from app.cli.common import cli

    r = CliRunner().invoke(cli, ["docs", "--check"])
    assert r.exit_code == 0 and "every generated section matches its data" in r.output

"""Which numbers are current (issue 45): a committed reproduction ledger records the code
version of its science files and each file's own hash (app/jobs/ledger.py); a page whose
generated sections read a ledger carries, at its top, the generated banner that names every
such data file older than its science files and the files changed since
(app/results/data_age.py). `gaitmend docs --check` (tests/test_docs_data.py) then fails when a
data file turns stale and its page does not say so; these tests check that every such page
has the banner, that it is at the top, and that it names what changed (on a planted stale
ledger, so none of them passes by finding nothing)."""

from __future__ import annotations

import json
from pathlib import Path

from app.jobs.ledger import Ledger, code_version, staleness
from app.jobs.reporting import sections_in
from app.results import data_age, docs_gen

ROOT = Path(__file__).resolve().parents[1]

# Pages that read a ledger but whose banner marker their owner has not added yet. A page
# listed here must really lack it: once it carries the marker, this test asks to drop it.
PENDING: dict[str, str] = {}  # a page that reads a ledger and has no banner yet, with the reason


def _declared():
    return {k: s for k, s in docs_gen.all_sections().items() if not k.startswith(data_age.PREFIX)}


def test_every_page_that_reads_a_ledger_says_at_its_top_how_old_its_data_is():
    declared = _declared()
    pages = data_age.page_data(ROOT, declared)
    assert {"README.md", "docs/tipping.md", "docs/energy.md", "docs/freegait.md", "docs/multigait.md",
            "docs/recovery_closed_loop.md"} <= set(pages)
    wrong = []
    for page, paths in pages.items():
        names = [n for n, _, _ in sections_in((ROOT / page).read_text())]
        banner = data_age.section_name(page)
        if page in PENDING:
            assert banner not in names, f"{page} carries its banner now: drop it from PENDING"
            continue
        if banner not in names:
            wrong.append(f"{page}: no '{banner}' section (it reads {', '.join(paths)})")
            continue
        readers = [i for i, n in enumerate(names) if n in declared and set(declared[n].data) & set(paths)
                   or n == docs_gen.SUMMARY]
        if readers and names.index(banner) > min(readers):
            wrong.append(f"{page}: '{banner}' comes after a section that reads its data")
        text = (ROOT / page).read_text()
        first_heading = text.find("\n## ") if "\n## " in text else len(text)
        if page != "README.md" and text.index(f"<!-- generated: {banner} ") > first_heading:
            wrong.append(f"{page}: '{banner}' is not above the page's first heading")
    assert not wrong, "\n".join(wrong)


def test_a_ledger_turned_stale_makes_its_page_fail_the_check_until_regenerated(docs_copy):
    # (every page matching its data before the change is tests/test_docs_data.py's to check)
    p = docs_copy / "docs/energy_knots.json"
    data = json.loads(p.read_text())
    assert staleness(data) is None  # re-run on this code (issue 45)
    victim = sorted(data["science_files"])[0]
    data["code_version"] = "0" * 12
    data["science_files"][victim] = "f" * 12
    p.write_text(json.dumps(data))
    diffs = docs_gen.check(docs_copy)
    assert len(diffs) == 1 and "docs/energy.md" in diffs[0]
    assert "energy_knots.json" in diffs[0] and victim in diffs[0] and "0" * 12 in diffs[0]
    assert docs_gen.write(docs_copy) == [docs_copy / "docs/energy.md"]  # `gaitmend docs` writes the banner
    assert "energy_knots.json (code 000000000000" in (docs_copy / "docs/energy.md").read_text()
    old, new = docs_gen.regenerate_page(docs_copy / "docs/energy.md", docs_copy)
    assert old == new


def test_a_current_ledger_leaves_the_banner_empty(docs_copy):
    text = (docs_copy / "docs/energy.md").read_text()
    body = dict((n, b) for n, _, b in sections_in(text))["data-age-energy"]
    stale = [p for p, _, _ in data_age.stale(data_age.page_data(ROOT, _declared())["docs/energy.md"])]
    assert ("energy_knots.json" in body) == ("docs/energy_knots.json" in stale) and "energy_knots.json" not in body


def test_staleness_names_the_files_changed_added_and_removed(tmp_path):
    (tmp_path / "sci").mkdir()
    for name in ("a.py", "b.py", "gone.py"):
        (tmp_path / "sci" / name).write_text(f"x = '{name}'\n")
    led = Ledger(tmp_path / "l.json", "exp", "cmd", {}, ["sci"], root=tmp_path)
    led.run("one", {"k": 1}, 0, lambda: {"v": 1.0})
    data = json.loads((tmp_path / "l.json").read_text())
    assert data["science_files"].keys() == {"sci/a.py", "sci/b.py", "sci/gone.py"}
    assert staleness(data, tmp_path) is None
    (tmp_path / "sci" / "a.py").write_text("x = 2\n")
    (tmp_path / "sci" / "new.py").write_text("y = 1\n")
    (tmp_path / "sci" / "gone.py").unlink()
    s = staleness(data, tmp_path)
    assert s["recorded"] == data["code_version"] and s["now"] == code_version(["sci"], tmp_path)
    assert s["changed"] == ["sci/a.py", "sci/gone.py (removed)", "sci/new.py (new)"]
    del data["science_files"]  # a ledger written before they were recorded
    assert staleness(data, tmp_path)["changed"] is None


def test_a_rerun_of_new_code_records_the_new_files_hashes(tmp_path):
    (tmp_path / "s.py").write_text("a = 1\n")
    Ledger(tmp_path / "l.json", "exp", "cmd", {}, ["s.py"], root=tmp_path).run("r", {}, 0, lambda: 1)
    old = json.loads((tmp_path / "l.json").read_text())
    (tmp_path / "s.py").write_text("a = 2\n")
    led = Ledger(tmp_path / "l.json", "exp", "cmd", {}, ["s.py"], root=tmp_path)
    assert led.data["science_files"] == old["science_files"]  # the file's runs are still the old code's
    led.run("r", {}, 0, lambda: 2)
    new = json.loads((tmp_path / "l.json").read_text())
    assert new["science_files"] != old["science_files"] and staleness(new, tmp_path) is None

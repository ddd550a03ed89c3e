"""The docs from their data (issue 28): every generated section of README.md and docs/*.md
re-rendered from the committed JSON its kind's renderer reads (app/jobs/reporting.py).

``write()`` rewrites the pages (``gaitmend docs``); ``check()`` lists the sections whose
text differs from what their data renders (``gaitmend docs --check``, and
tests/test_docs_data.py). README.md's results summary (``results-summary``) is the lines
of every kind's sections marked ``readme``, in the registry's order."""

from __future__ import annotations

import difflib
from pathlib import Path

from app.jobs.ledger import ROOT
from app.jobs.registry import KINDS
from app.jobs.reporting import SUMMARY, Section, pages, regenerate, sections_in
from app.results import (benchmarks, examples, loadtest, notebook_figures, observed, reproducibility,
                         robot_figures, scaling)


def all_sections() -> dict[str, Section]:
    """Every section any kind's experiments declare, the notebook page's measured figures
    (app/results/notebook_figures.py) and the benchmark figures of every kind
    (app/results/benchmarks.py, `gaitmend reproduce bench`) and of the README's example lines
    (app/results/examples.py, `gaitmend reproduce readme-examples`) and the submission latency
    (app/results/loadtest.py, scripts/loadtest.py) and what the test suite observes
    (app/results/observed.py), a study's scaling over workers (app/results/scaling.py) and
    the robot layer's timings (app/results/robot_figures.py) and whether results reproduce on
    other machines (app/results/reproducibility.py), by name (a name is unique)."""
    from app.adapt.reproduce import report as adapt_report  # docs/adapt.md's evaluation (issue 44)

    out: dict[str, Section] = {}
    declared = [s for kind in KINDS.values() for exp in kind.experiments() for s in exp.sections]
    for s in [*declared, *notebook_figures.SECTIONS, *benchmarks.sections(), *examples.sections(),
              *loadtest.sections(), *observed.sections(), *scaling.sections(),
              *robot_figures.sections(), *adapt_report.sections(), *reproducibility.sections()]:
        if s.name in out or s.name == SUMMARY:
            raise ValueError(f"generated section {s.name!r} is declared twice")
        out[s.name] = s
    from app.results import data_age  # each page's banner naming its data older than its code (issue 45)

    for s in data_age.sections(out):
        out[s.name] = s
    return out


def renderer(root: Path = ROOT, sections: dict[str, Section] | None = None):
    """name -> the section's text from the data under ``root``."""
    sections = all_sections() if sections is None else sections

    def render(name: str) -> str:
        if name == SUMMARY:
            lines = [sections[n].text(root) for n in sections if sections[n].readme]
            return "".join(lines)
        if name not in sections:
            raise KeyError(f"no kind declares the generated section {name!r} (app/jobs/<kind>/experiments.py)")
        return sections[name].text(root)

    return render


def regenerate_page(path: Path, root: Path = ROOT, sections: dict[str, Section] | None = None) -> tuple[str, str]:
    """(the page as it is, the page with its generated sections rendered afresh)."""
    old = path.read_text()
    return old, regenerate(old, renderer(root, sections))


def check(root: Path = ROOT, sections: dict[str, Section] | None = None) -> list[str]:
    """A unified diff per page whose generated text differs from its data's; empty when
    every section matches."""
    out = []
    for p in pages(root):
        old, new = regenerate_page(p, root, sections)
        if old != new:
            diff = difflib.unified_diff(old.splitlines(), new.splitlines(), f"{p.relative_to(root)} (as written)",
                                        f"{p.relative_to(root)} (from its data)", lineterm="", n=1)
            out.append("\n".join(diff))
    return out


def write(root: Path = ROOT, sections: dict[str, Section] | None = None) -> list[Path]:
    """Rewrite every page whose generated sections differ from their data; the pages written."""
    done = []
    for p in pages(root):
        old, new = regenerate_page(p, root, sections)
        if old != new:
            p.write_text(new)
            done.append(p)
    return done


def generated_names(root: Path = ROOT) -> dict[str, list[str]]:
    """{page: names of its generated sections}."""
    return {str(p.relative_to(root)): [n for n, _, _ in sections_in(p.read_text())] for p in pages(root)}

"""Claims in prose carry their data (issue 45). Every number in a generated block comes from
committed JSON (tests/test_docs_data.py); the prose around the blocks is written by hand,
and a hand-written sentence once said a comparison was "shown", a value "raised" or that
falls were "the same draws both ways" where the data said otherwise. Here a hand-written
sentence of README.md or docs/*.md that makes such a claim

- a verdict or comparison word (``shown``, ``better``, ``raised``) next to a result figure
  (a decimal number, a percentage, "k of n" or "k/n"), or
- a sameness claim that needs no figure to be wrong ("the same ... both ways", "the same
  draws", "changes nothing"),

must sit inside a generated block, or carry a marker ``<!-- data: docs/<file>.json -->`` in
its paragraph naming the committed JSON it rests on, and every decimal number of the
sentence must be a value that JSON holds (at the sentence's precision). The renderers that
write the README's claims are held to the same data by the last tests (the summary lines of
tipping, energy and freegait: issue 45's items)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from app.jobs.reporting import MARKER

ROOT = Path(__file__).resolve().parents[1]

CLAIM = re.compile(r"\bshown\b|\bbetter\b|\braised\b", re.I)
SAMENESS = re.compile(r"\bsame\b(?:\s+\S+){0,4}\s+both ways\b|\bthe same draws\b|\bchanges nothing\b", re.I)
FIGURE = re.compile(r"(?<![\w.#/-])[-+]?\d+\.\d+(?![\w/.]\d)|(?<![\w.])\d+(?:\.\d+)?\s?%|\b\d+ of \d+\b|(?<![\w./])\d+/\d+(?![\w/^])")
RULE = re.compile(r"\b95 %")  # the confidence level every interval here uses: a convention, not a result
DECIMAL = re.compile(r"(?<![\w.#/-])[-+]?(\d+\.(\d+))(?![\w/.]\d)")
CITE = re.compile(r"<!-- data: (docs/[\w.-]+\.json) -->")
FENCE = re.compile(r"```.*?```|~~~.*?~~~", re.S)


def _plain(paragraph: str) -> str:
    """The paragraph as read: inline code, link targets and comments out, one line."""
    text = re.sub(r"`[^`]*`", " ", paragraph)
    text = re.sub(r"\]\([^)]*\)", "]", text)
    text = re.sub(r"<!--.*?-->", " ", text, flags=re.S)
    return " ".join(text.split())


def sentences(text: str):
    """(paragraph's cited JSON files, sentence) of every hand-written sentence of a page:
    outside generated blocks and fenced code."""
    text = FENCE.sub("\n\n", MARKER.sub("\n\n", text))
    text = re.sub(r"\n(?=\s*(?:[-*]|\d+\.) |\s*\|)", "\n\n", text)  # a list item or table row is its own paragraph
    for para in re.split(r"\n\s*\n", text):
        cited = CITE.findall(para)
        for s in re.split(r"(?<=[.;])\s+(?=[A-Z(*])", _plain(para)):
            yield cited, s


def _numbers(data) -> list[float]:
    if isinstance(data, bool):
        return []
    if isinstance(data, (int, float)):
        return [float(data)]
    if isinstance(data, dict):
        return [x for v in data.values() for x in _numbers(v)]
    if isinstance(data, list):
        return [x for v in data for x in _numbers(v)]
    return []


def _holds(numbers: list[float], figure: str, digits: int) -> bool:
    want = float(figure)
    return any(round(x, digits) == want or round(100 * x, digits) == want for x in numbers)


def problems(root: Path) -> list[str]:
    """Every unbacked claim of README.md and docs/*.md under ``root``, page and sentence."""
    out = []
    for page in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        rel = page.relative_to(root)
        for cited, s in sentences(page.read_text()):
            claim = (CLAIM.search(s) and FIGURE.search(RULE.sub(" ", s))) or SAMENESS.search(s)
            if not claim:
                continue
            if not cited:
                out.append(f"{rel}: a claim with no generated block or data marker: {s[:300]!r}")
                continue
            missing = [c for c in cited if not (root / c).exists()]
            if missing:
                out.append(f"{rel}: cites {missing}, not committed: {s[:200]!r}")
                continue
            nums = [x for c in cited for x in _numbers(json.loads((root / c).read_text()))]
            for m in DECIMAL.finditer(s):
                if not _holds(nums, m.group(0), len(m.group(2))):
                    out.append(f"{rel}: {m.group(0)} is in no value of {', '.join(cited)}: {s[:300]!r}")
    return out


def test_every_hand_written_claim_is_generated_or_cites_its_data():
    found = problems(ROOT)
    assert not found, "\n".join(found)

"""The compare page at a phone's width (issue 25): the convergence plot's legend names each
job and series in full, on two lines where one is wider than the plot (plotly cut it), all
of it above the plot's area (not scrolled over the lines); on a desktop the names stay on
one line."""

from __future__ import annotations

import io
import re
import time

import numpy as np
import pytest
from conftest import SECOND
from PIL import Image
from playwright.sync_api import expect

import glance


@pytest.fixture(scope="module")
def other_job(server) -> str:
    """A second recovery job with a 3 s walk: long enough for its target to be judged, so
    the compare table has a 'recovery target' row whose value is met or not met."""
    spec = SECOND | {"search": {**SECOND["search"], "seed": 5}, "sim": {"duration_s": 3.0}}
    with server.client("alice") as c:
        jid = c.post("/api/jobs", json=spec).json()["id"]
        for _ in range(240):
            if c.get(f"/api/jobs/{jid}").json()["status"] in ("succeeded", "failed", "cancelled"):
                break
            time.sleep(0.5)
        assert c.get(f"/api/jobs/{jid}").json()["status"] == "succeeded"
    return jid


def test_the_compare_legend_fits_a_phone(new_page, server, shots, second_job, other_job):
    url = f"{server.url}/compare?ids={second_job},{other_job}"
    for viewport in (glance.PHONE, glance.DESKTOP):
        pg = new_page(viewport=viewport)
        pg.goto(url)
        plot = pg.locator('[id^="plot-compare-"][data-rendered="1"]')
        expect(plot).to_have_count(1, timeout=30_000)
        names = plot.evaluate("d => d.data.map(t => t.name)")
        assert len(names) >= 2 and all(n.startswith("recovery · lost 1,6") for n in names), names
        box = plot.bounding_box()
        legend = plot.locator("g.legend").bounding_box()
        assert legend["x"] >= box["x"] - 0.5 and legend["x"] + legend["width"] <= box["x"] + box["width"] + 0.5, \
            (viewport, legend, box)
        area = plot.locator(".draglayer .nsewdrag").first.bounding_box()
        assert legend["y"] + legend["height"] <= area["y"] + 1, (viewport, legend, area)  # above the lines, not on them
        if viewport is glance.PHONE:
            glance.page_shot(pg, shots / "compare-legend-390.png")
            glance.fits_width(pg)
        else:
            assert not any("<br>" in n for n in names), names  # the desktop's legend as it was


def test_every_job_has_its_column_on_a_phone_and_a_verdict_is_said_once(new_page, server, second_job, other_job):
    pg = new_page(viewport=glance.PHONE)
    pg.goto(f"{server.url}/compare?ids={second_job},{other_job}")
    table = pg.locator("table.metrics")
    expect(table.locator("tbody tr").first).to_be_visible(timeout=30_000)
    heads = table.locator("thead th")
    assert heads.count() == 3, heads.all_inner_texts()  # Metric and the two jobs
    wrap = pg.locator(".table-wrap").filter(has=table).bounding_box()
    for i, jid in ((2, second_job), (3, other_job)):
        head = table.locator(f"thead th:nth-child({i})")
        expect(head).to_be_visible()
        expect(head.locator("a")).to_have_attribute("href", f"/jobs/{jid}")
        cells = table.locator(f"tbody tr > td:nth-child({i})")
        assert cells.count() == table.locator("tbody tr").count()
        for k in range(cells.count()):
            expect(cells.nth(k)).to_be_visible()
        # on screen, not behind the wrapper's sideways scroll
        box = head.bounding_box()
        assert box["x"] + box["width"] <= wrap["x"] + wrap["width"] + 1, (i, box, wrap)
    # the target row of the 3 s job: the verdict once, in its mark (it read 'not met ✗ not met')
    row = table.locator("tbody tr").filter(has=pg.locator("th", has_text=re.compile(r"^recovery target$")))
    expect(row).to_have_count(1)
    said = row.locator("td").nth(1).inner_text().strip()
    assert said in ("✓ met", "✗ not met"), said
    for text in table.locator("tbody td").all_inner_texts():
        assert text.count("not met") <= 1 and not re.search(r"(?<!not )\bmet\b.*\bmet\b", text), text
    # a number keeps its value beside the mark
    judged = table.locator("tbody td:has(.mark)")
    assert any(re.match(r"^-?[\d.]+\s*[✓✗]", t.strip()) for t in judged.all_inner_texts()), judged.all_inner_texts()


def _edges(wrap) -> tuple[float, float]:
    """Mean brightness of the wrapper's outer 6 px at its left and right edges (a header-free
    band in the middle of its height), from a screenshot."""
    img = np.asarray(Image.open(io.BytesIO(wrap.screenshot())).convert("L"), dtype=float)
    band = img[img.shape[0] // 3: 2 * img.shape[0] // 3]
    return band[:, :6].mean(), band[:, -6:].mean()


def test_a_table_wider_than_its_card_shows_a_shadow_where_it_scrolls(new_page, server, second_job, other_job):
    """A wide table scrolls inside its focusable wrapper with a shadow at the edge that has
    more (energy's Controls, 29 columns, was cut at the card's edge at 1280 px with no cue):
    on the right at the start, on the left at the end, none on a table that fits."""
    pg = new_page(viewport=glance.DESKTOP)
    pg.goto(f"{server.url}/compare?ids={second_job},{other_job}")
    wrap = pg.locator(".table-wrap").filter(has=pg.locator("table.metrics"))
    expect(wrap.locator("tbody tr").first).to_be_visible(timeout=30_000)
    assert wrap.get_attribute("tabindex") == "0" and wrap.get_attribute("role") == "region"
    left, right = _edges(wrap)
    assert abs(left - right) < 8, (left, right)  # it fits: no shadow either side
    wrap.evaluate("w => { w.style.width = '260px'; w.scrollLeft = 0; }")
    assert wrap.evaluate("w => w.scrollWidth > w.clientWidth + 50")
    left, right = _edges(wrap)
    # a cut cell alone darkens an edge by 9-15 levels of 255, the shadow by 60-70
    assert right < left - 30, (left, right)
    wrap.evaluate("w => { w.scrollLeft = w.scrollWidth; }")
    left, right = _edges(wrap)
    assert left < right - 30, (left, right)

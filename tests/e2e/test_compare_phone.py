"""The compare page at a phone's width (issue 25): the convergence plot's legend names each
job and series in full, on two lines where one is wider than the plot (plotly cut it), all
of it above the plot's area (not scrolled over the lines); on a desktop the names stay on
one line."""

from __future__ import annotations

import time

from conftest import SECOND
from playwright.sync_api import expect

import glance


def _other_job(server) -> str:
    with server.client("alice") as c:
        jid = c.post("/api/jobs", json=SECOND | {"search": {**SECOND["search"], "seed": 5}}).json()["id"]
        for _ in range(240):
            if c.get(f"/api/jobs/{jid}").json()["status"] in ("succeeded", "failed", "cancelled"):
                break
            time.sleep(0.5)
        assert c.get(f"/api/jobs/{jid}").json()["status"] == "succeeded"
    return jid


def test_the_compare_legend_fits_a_phone(new_page, server, shots, second_job):
    url = f"{server.url}/compare?ids={second_job},{_other_job(server)}"
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
            pg.screenshot(path=shots / "compare-legend-390.png", full_page=True)
            glance.fits_width(pg)
        else:
            assert not any("<br>" in n for n in names), names  # the desktop's legend as it was

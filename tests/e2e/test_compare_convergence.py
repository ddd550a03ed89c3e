"""The job page's convergence plot against the bundle's convergence figure (issue 25): the
same series in the same colours and dashes (the bundle drew matplotlib's default cycle,
the page the colour table's roles)."""

from __future__ import annotations

import re

from playwright.sync_api import expect

DASHES = {"solid": None, "dot": "dot", "dash": "dash"}


def test_the_page_and_the_bundle_draw_convergence_alike(page, server, second_job):
    page.goto(f"{server.url}/jobs/{second_job}")
    plot = page.locator("#plot-convergence[data-rendered='1']")
    expect(plot).to_be_attached(timeout=30_000)
    lines = plot.evaluate("d => d.data.map(t => [t.line.color, t.line.dash || 'solid'])")
    assert len(lines) >= 3, lines  # best, mean, worst of a recovery run
    with server.client("alice") as c:
        files = {f["path"]: f["url"] for f in c.get(f"/api/jobs/{second_job}/views").json()["files"]}
        svg = c.get(files["plots/convergence.svg"]).text
    # each line of the figure: its stroke colour and whether it is dashed
    drawn = {(m.group(1), "dasharray" in m.group(0))
             for m in re.finditer(r'style="fill: none;[^"]*?stroke: (#[0-9a-f]{6})[^"]*"', svg)}
    for color, dash in lines:
        assert (color, dash != "solid") in drawn, (color, dash, sorted(drawn))
    assert not {c for c, _ in drawn} & {"#1f77b4", "#ff7f0e", "#2ca02c"}, drawn  # matplotlib's own cycle

"""Seeing the map (issue 43, item 4), in Chromium at 1280 and 390 px, on a small real
repertoire job: the job page draws the archive in 2-D slices coloured by forward distance
(every elite once per slice, the replayable ones ringed), QD-score over evaluations with
the random control's (the Convergence chart) and coverage too (the bundle's progress
figure), the final figures beside the control's, and a replay button per ringed elite that
plays that elite's own scene."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect
from service_support import wait_for

import glance

SPEC = {"kind": "repertoire", "seed": 4, "archive": {"cells": 30},
        "search": {"iterations": 3, "batch_size": 8, "checkpoint_every": 3},
        "sim": {"duration_s": 1.0, "settle_s": 0.2}, "evidence": {"rescore_elites": 2}}


@pytest.fixture(scope="module")
def map_job(server) -> tuple[str, dict, dict]:
    """(id, summary, views) of alice's small map, submitted through the API, succeeded."""
    with server.client("alice") as c:
        jid = c.post("/api/jobs", json=SPEC).json()["id"]
        wait_for(lambda: c.get(f"/api/jobs/{jid}").json()["status"] in ("succeeded", "failed", "cancelled"), 300,
                 "the repertoire job to finish", interval=0.3, proc=server.proc)
        job = c.get(f"/api/jobs/{jid}").json()
        assert job["status"] == "succeeded", job["error"]
        return jid, job["summary"], c.get(f"/api/jobs/{jid}/views").json()


def _plot(pg, pid: str) -> list[dict]:
    """The traces plotly drew in a panel (what is on screen, not what was sent)."""
    return pg.evaluate(f"""() => document.getElementById({pid!r}).data.map(t => ({{
        name: t.name, type: t.type, n: (t.x || []).length, x: t.x, y: t.y, text: t.text,
        color: t.marker && t.marker.color, xaxis: t.xaxis, yaxis: t.yaxis }}))""")


@pytest.mark.parametrize("width", ["1280", "390"])
def test_the_page_shows_the_map_its_progress_and_replays_picked_elites(new_page, server, shots, map_job, width):
    jid, summary, views = map_job
    e = summary["elites"]
    n, dims = len(e["cell"]), len(summary["descriptor"]["names"])
    tracks = views["replay"]
    elites = [t for t in tracks if t["name"].startswith("elite_")]
    ringed = sorted(int(t["name"][6:]) for t in elites)
    assert tracks[0]["name"] == "best" and 1 <= len(elites) <= 12 and len(elites) == min(n, 12)
    assert set(ringed) <= set(e["cell"])

    pg = new_page(viewport=glance.DESKTOP if width == "1280" else glance.PHONE)
    pg.goto(f"{server.url}/jobs/{jid}")
    expect(pg.locator("body[data-drawn='1']")).to_be_attached(timeout=90_000)

    # the map: one scatter of every elite per 2-D slice, coloured by its forward distance
    expect(pg.locator("#panel-map")).to_be_visible()
    drawn = _plot(pg, "plot-map")
    dots = [t for t in drawn if t["name"] == "elites"]
    rings = [t for t in drawn if t["name"] == "has a replay"]
    assert len(dots) == dims // 2 + dims % 2 == len(rings)
    by_cell = {c: i for i, c in enumerate(e["cell"])}
    for t in dots:
        assert t["n"] == n and sorted(t["text"]) == sorted(f"cell {c}" for c in e["cell"])
        for text, colour in zip(t["text"], t["color"]):
            assert colour == pytest.approx(e["objective"][by_cell[int(text[5:])]], abs=1e-5)
    first = dots[0]  # slice 0 is the descriptor's dimensions 0 and 1
    for text, x, y in zip(first["text"], first["x"], first["y"]):
        m = e["measures"][by_cell[int(text[5:])]]
        assert (x, y) == (pytest.approx(m[0], abs=1e-5), pytest.approx(m[1], abs=1e-5))
    assert sorted(int(s.split(":")[0][5:]) for s in rings[0]["text"]) == ringed
    expect(pg.locator("#panel-map .caption")).to_contain_text(f"{n} elites in {summary['archive']['cells']} cells")

    # progress over evaluations against the random control: QD-score drawn, coverage in the bundle's figure
    conv = {t["name"]: t for t in _plot(pg, "plot-convergence")}
    assert {"MAP-Elites QD-score", "random search QD-score"} <= set(conv)
    assert conv["MAP-Elites QD-score"]["n"] == SPEC["search"]["iterations"]
    assert conv["MAP-Elites QD-score"]["x"][-1] == SPEC["search"]["iterations"] * SPEC["search"]["batch_size"]
    assert conv["MAP-Elites QD-score"]["y"][-1] == pytest.approx(summary["archive"]["qd_score"])
    progress = pg.locator("img[alt='bundle figure progress']")
    progress.scroll_into_view_if_needed()  # loaded lazily
    pg.wait_for_function("(img) => img.complete && img.naturalWidth > 100", arg=progress.element_handle(),
                         timeout=30_000)
    table = pg.locator("#panel-map_vs_random table")
    expect(table).to_contain_text("coverage (%)")
    expect(table).to_contain_text(f"{100 * summary['archive']['coverage']:.1f}")

    # every ringed elite is listed and has its own replay button
    rows = pg.locator("#panel-replays tbody tr")
    expect(rows).to_have_count(len(elites))
    buttons = pg.locator("#replay-tracks button")
    expect(buttons).to_have_count(len(tracks))
    for t in elites:
        expect(pg.locator(f'#replay-tracks button[data-track="{t["name"]}"]')).to_have_text(t["label"])
        expect(pg.locator("#panel-replays")).to_contain_text(t["label"])
    glance.page_shot(pg, shots / f"repertoire-job-{width}.png")
    glance.no_axe_faults(pg, "repertoire job page")
    if width == "390":
        glance.fits_width(pg)
        return
    # picking an elite plays that elite's own scene, and back to the best gait
    pick = next(t for t in elites if int(t["name"][6:]) != summary["best"]["cell"]) if len(elites) > 1 else elites[0]
    glance.switch_track(pg, pick)
    pg.screenshot(path=shots / "repertoire-replay-elite-1280.png", full_page=False)
    glance.switch_track(pg, tracks[0])

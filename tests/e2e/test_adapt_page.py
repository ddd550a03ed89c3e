"""The adaptation session's page (/adaptations/{id}) in a real headless Chromium, at a
phone's 390 px and a desktop's 1280 px: the gait to try next, a measurement typed into the
form and posted, the next gait shown, the trials in order with their measurements, the stop
decision and why, the map drawn by prior and by posterior; a bad number is refused naming
its field. The map is a real repertoire job the served worker builds (small)."""

from __future__ import annotations

import pytest
from conftest import DESKTOP
from service_support import wait_for

import glance
from glance import PHONE

SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 8, "checkpoint_every": 4},
        "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
        "evidence": {"rescore_elites": 0, "random_control": False}}


@pytest.fixture(scope="module")
def repertoire(server) -> str:
    with server.client("alice") as c:
        jid = c.post("/api/jobs", json=SPEC).json()["id"]
        wait_for(lambda: c.get(f"/api/jobs/{jid}").json()["status"] in ("succeeded", "failed", "cancelled"), 300,
                 "the repertoire job", interval=0.5, proc=server.proc)
        job = c.get(f"/api/jobs/{jid}").json()
    assert job["status"] == "succeeded", job["error"]
    return jid


def _session(server, jid: str) -> dict:
    with server.client("alice") as c:
        r = c.post("/api/adaptations", json={"repertoires": [jid], "stop": {"max_trials": 3}, "name": "e2e"})
        assert r.status_code == 201, r.text
        return r.json()


@pytest.mark.parametrize("viewport", [PHONE, DESKTOP], ids=["390", "1280"])
def test_enter_a_measurement_and_get_the_next_gait(new_page, server, repertoire, viewport, shots):
    s = _session(server, repertoire)
    pg = new_page(viewport=viewport)
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(f"{server.url}/adaptations/{s['id']}")
    first = s["next"]
    gait = pg.locator("#next-gait")
    gait.wait_for()
    assert f"Trial 1: run elite {first['elite']} (cell {first['cell']})" in gait.inner_text()
    assert pg.locator("#stop-decision").inner_text() == "Go on."
    assert pg.locator("#next-replay").get_attribute("href") == f"/jobs/{repertoire}"
    pg.locator("#plot-prior[data-rendered='1'] .main-svg").first.wait_for()
    pg.locator("#plot-posterior[data-rendered='1'] .main-svg").first.wait_for()
    glance.fits_width(pg)
    assert pg.locator("#duration_s").input_value() == "1.0" or float(pg.locator("#duration_s").input_value()) == 1.0

    # a bad number: refused, the field named, nothing stored
    pg.locator("#forward_m").fill("1e9")
    pg.locator("#trial-submit").click()
    alert = pg.locator("#ad-error")
    alert.wait_for(state="visible")
    assert "forward_m" in alert.inner_text()
    assert pg.locator("#forward_m").get_attribute("aria-invalid") == "true"

    pg.locator("#forward_m").fill("-0.004")  # backwards: below any prediction, no early stop
    pg.locator("#lateral_m").fill("-0.01")
    pg.locator("#yaw_deg").fill("2.5")
    pg.locator("#note").fill("first try")
    pg.locator("#trial-submit").click()
    pg.locator("#trials tbody tr").first.wait_for()
    with server.client("alice") as c:
        after = c.get(f"/api/adaptations/{s['id']}").json()
    assert [(t["trial"], t["forward_m"], t["lateral_m"], t["yaw_deg"], t["fell"], t["note"]) for t in after["trials"]] \
        == [(1, -0.004, -0.01, 2.5, False, "first try")]
    assert (after["trials"][0]["map"], after["trials"][0]["elite"]) == (first["map"], first["elite"])
    nxt = after["next"]
    assert nxt["trial"] == 2
    wait_for(lambda: f"Trial 2: run elite {nxt['elite']} (cell {nxt['cell']})" in gait.inner_text(), 10,
             "the next gait on the page")
    row = pg.locator("#trials tbody tr").first.inner_text()
    assert "-0.004" in row and "first try" in row
    assert pg.locator("#stop-why").inner_text() == after["decision"]["reason"]
    assert pg.locator("#trial-legend").inner_text() == "Measured on trial 2"
    assert pg.locator("#ad-error").is_hidden() and pg.locator("#forward_m").get_attribute("aria-invalid") is None
    glance.fits_width(pg)
    glance.page_shot(pg, shots / f"adapt-{viewport['width']}.png")

    # trials until the session stops (at the latest after max_trials 3); the page says so and why
    while pg.locator("#trial-form").is_visible():
        n = len(pg.locator("#trials tbody tr").all())
        assert n < 3
        pg.locator("#forward_m").fill("-0.01")
        pg.locator("#trial-submit").click()
        wait_for(lambda: len(pg.locator("#trials tbody tr").all()) == n + 1, 10, "the trial's row")
    pg.locator("#next-none").wait_for()
    with server.client("alice") as c:
        done = c.get(f"/api/adaptations/{s['id']}").json()
    assert done["status"] == "finished" and done["decision"]["stop"]
    assert pg.locator("#stop-decision").inner_text() == "Stop."
    assert pg.locator("#stop-why").inner_text() == done["decision"]["reason"]
    assert [r.inner_text().split("\t")[0] for r in pg.locator("#trials tbody tr").all()] == \
        [str(t["trial"]) for t in done["trials"]]
    glance.no_axe_faults(pg, "adaptation")
    assert not errors, errors

"""Your robot in the browser (issue 23): the Add robot page uploads a hexapod built here with
MjSpec (four joints a leg, other axes and lengths than the JetHexa's), draws the legs it
found (top view and 3D), takes an edited leg name, and saves; a hostile upload shows the
API's refusal; the New job form then offers the robot, draws *its* legs, and a short
recovery with one leg lost (named by the edited map) runs to its page, which names the
robot and its damage. axe: 0 critical / serious on the page at 1280 and 390 px."""

from __future__ import annotations

import re
import sys
import zipfile
from pathlib import Path
from urllib.parse import unquote

import httpx
from playwright.sync_api import expect

import glance

sys.path.insert(0, str(Path(__file__).parents[1] / "robots"))
from legged_models import HEXAPOD_OTHER, build  # noqa: E402

JOB_TIMEOUT_MS = 180_000  # the shared e2e server may still be running earlier tests' jobs (a CI run waited 90 s in "queued")
ENTITY_BOMB = b'<?xml version="1.0"?><!DOCTYPE m [<!ENTITY a "aaaaaaaaaa">]><mujoco model="x">&a;</mujoco>'


def _model(tmp_path) -> Path:
    path = tmp_path / "hexapod_other.xml"
    path.write_text(build(HEXAPOD_OTHER).to_xml())
    return path


def _own_robots(server) -> list[dict]:
    with server.client("alice") as c:
        return [r for r in c.get("/api/robots").json() if not r["builtin"]]


def _check(page, server, model: Path):
    page.goto(f"{server.url}/robots/new")
    page.set_input_files("#up-model", str(model))
    page.click("#up-check")
    expect(page.locator("#legs-card")).to_be_visible(timeout=30_000)


def test_upload_confirm_edit_save_then_recover_through_the_form(page, new_page, server, shots, tmp_path):
    before = {r["id"] for r in _own_robots(server)}
    # a refused upload: the API's 4xx message, naming what was refused, and nothing stored
    bomb = tmp_path / "bomb.xml"
    bomb.write_bytes(ENTITY_BOMB)
    page.goto(f"{server.url}/robots/new")
    expect(page.locator('header nav a[aria-current="page"]')).to_have_text("Add robot")
    page.set_input_files("#up-model", str(bomb))
    page.click("#up-check")
    err = page.locator("#up-error")
    expect(err).to_be_visible(timeout=20_000)
    expect(err).to_contain_text(re.compile(r"Refused \(4\d\d\): refused: .*(DTD|entit)", re.I))
    expect(page.locator("#legs-card")).to_be_hidden()

    # the detected legs, drawn and listed; the check stores nothing
    model = _model(tmp_path)
    _check(page, server, model)
    expect(err).to_be_hidden()
    rows = page.locator("#legmap-rows tr")
    expect(rows).to_have_count(6)
    expect(page.locator("#legmap-drawing svg .leg")).to_have_count(6)
    expect(page.locator("#legmap-drawing svg .leg text")).to_have_text([str(i) for i in range(1, 7)])
    expect(page.locator('#legmap-3d[data-rendered="1"]')).to_be_attached(timeout=30_000)
    names = [page.locator(f"#lm-name-{i}").input_value() for i in range(6)]
    sides = [page.locator(f"#lm-side-{i}").input_value() for i in range(6)]
    assert sorted(names) == ["L0", "L1", "L2", "R0", "R1", "R2"], names
    assert all(s == ("left" if n.startswith("L") else "right") for n, s in zip(names, sides)), (names, sides)
    first = names.index("L0")
    assert page.locator(f"#lm-joints-{first}").input_value() == "L0_j0, L0_j1, L0_j2, L0_j3"
    # front at the top: the front legs (order 0) are drawn above the rear ones (order 2)
    y = {n: float(page.locator(f'#legmap-drawing .leg[data-leg="{n}"] .foot').get_attribute("cy")) for n in ("L0", "L2")}
    assert y["L0"] < y["L2"], y
    assert {r["id"] for r in _own_robots(server)} == before
    glance.no_axe_faults(page, "add robot")
    glance.page_shot(page, shots / "robot-add-desktop.png")

    # edit a leg's name (the drawing follows), save: the stored map carries the edit
    page.fill(f"#lm-name-{first}", "front_left")
    expect(page.locator('#legmap-drawing .leg[data-leg="front_left"]')).to_have_count(1)
    page.click("#lm-save")
    ok = page.locator("#save-ok")
    expect(ok).to_contain_text("Saved", timeout=30_000)
    robot_id = ok.get_attribute("data-robot-id")
    with server.client("alice") as c:
        stored = c.get(f"/api/robots/{robot_id}").json()
    assert "front_left" in [leg["name"] for leg in stored["legs"]["legs"]]
    assert stored["kinds"] == ["recovery", "repertoire"]
    expect(page.locator(f'#mine-rows tr[data-id="{robot_id}"]')).to_contain_text("front_left")
    # the saved robot in viser's client: its recording is served by a signed link, and drawn
    expect(page.locator("#preview-card")).to_be_visible(timeout=10_000)
    src = page.locator("#robot-preview").get_attribute("src")
    link = unquote(src.split("playbackPath=", 1)[1])
    recording = httpx.get(server.url + link, timeout=60)
    assert recording.status_code == 200 and len(recording.content) > 1000, recording.status_code
    assert httpx.get(server.url + link.replace("sig=", "sig=0"), timeout=10).status_code in (401, 404)
    share = glance.canvas_drawn(page, "#robot-preview", enough=0.02, rounds=20, every_ms=700)
    page.locator("#preview-card").screenshot(path=str(shots / "robot-preview-1280.png"))
    assert share > 0.02, f"the preview shows {share:.1%} non-background pixels"

    phone = new_page(viewport=glance.PHONE)  # the same model as one zip of its folder
    archive = tmp_path / "hexapod.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.write(model, "hexapod/hexapod_other.xml")
    _check(phone, server, archive)
    expect(phone.locator("#legmap-rows tr")).to_have_count(6)
    glance.fits_width(phone)
    glance.no_axe_faults(phone, "add robot")
    glance.page_shot(phone, shots / "robot-add-phone.png")

    # the New job form offers it and draws its legs; one leg lost, by the edited name
    page.goto(f"{server.url}/")
    page.select_option("#kind", "recovery")
    page.select_option("#robot", robot_id)
    expect(page.locator("#mapped-picker")).to_be_visible()
    expect(page.locator("#damage-picker")).to_be_hidden()
    expect(page.locator("#mapped-drawing .leg")).to_have_count(6)
    page.locator('#mapped-drawing .leg[data-leg="front_left"]').click()
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost leg front_left.")
    expect(page.locator('#mapped-joints select[data-leg="front_left"]')).to_have_count(0)
    expect(page.locator("#mapped-joints select")).to_have_count(5 * 4)  # the working legs' joints
    page.locator("#mapped-details > summary").click()
    page.locator("#new-job").screenshot(path=str(shots / "robot-form-desktop.png"))
    glance.no_axe_faults(page, "new job form, your robot")
    # a damage it cannot stand on: the API's 422 naming robot_damage, inline, nothing queued
    for leg in ("L1", "L2"):
        page.locator(f'#mapped-drawing .leg[data-leg="{leg}"]').click()
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost legs front_left, L1, L2.")
    page.click("#submit")
    # refused before the form would ask to confirm a long job: the default budget is over the
    # confirmation threshold once this server has timed a recovery job (another test's), and
    # the dry run (/api/web/check) answers the damage as POST /api/jobs does
    expect(page.locator("#form-error")).to_contain_text("robot_damage", timeout=30_000)
    expect(page.locator("#confirm")).to_be_hidden()
    for leg in ("L1", "L2"):
        page.locator(f'#mapped-drawing .leg[data-leg="{leg}"]').press("Enter")
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost leg front_left.")
    # a joint by name: locked at an angle, then working again (the job runs with the lost leg only)
    joint = page.locator('#mapped-joints select[data-leg="L1"][data-joint="L1_j2"]')
    joint.select_option("locked")
    joint.locator("xpath=following-sibling::input").fill("-20")
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost leg front_left; L1 L1_j2 locked at -20°.")
    expect(page.locator('#mapped-drawing .leg[data-leg="L1"] .joint.locked')).to_have_count(1)
    joint.select_option("passive")
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost leg front_left; L1 L1_j2 passive.")
    joint.select_option("ok")
    expect(page.locator("#mapped-summary")).to_have_text("Damage: lost leg front_left.")
    page.fill("#f-search-population", "6")
    page.fill("#f-search-generations", "2")
    page.fill("#f-sim-duration-s", "1.5")
    if page.locator("#f-controls-random-search").is_checked():
        page.locator("#f-controls-random-search").evaluate("e => { e.closest('details').open = true; }")
        page.uncheck("#f-controls-random-search")
    page.locator("#f-robustness-cases").evaluate("e => { e.closest('details').open = true; }")
    page.fill("#f-robustness-cases", "[]")
    page.fill("#f-robustness-held-out", "3")  # judged on held-out random models, as the built-in robot is
    # issue 47, on every robot: the closed loop with balance, as a user sets it in the form
    page.locator("#f-control-mode").evaluate("e => { e.closest('details').open = true; }")
    page.select_option("#f-control-mode", "closed_loop")
    page.fill("#f-control-balance-gain", "1")
    page.click("#submit")
    done = page.locator("#form-ok")
    expect(done).to_be_visible(timeout=30_000)
    job_id = done.locator("a").get_attribute("href").rsplit("/", 1)[1]
    with server.client("alice") as c:
        spec = c.get(f"/api/jobs/{job_id}").json()["spec"]
    assert spec["robot"] == robot_id and spec["robot_damage"]["lost_legs"] == ["front_left"], spec
    assert spec["control"]["mode"] == "closed_loop" and spec["control"]["balance_gain"] == 1.0, spec["control"]

    page.goto(f"{server.url}/jobs/{job_id}")
    expect(page.locator("#status-line .badge")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)
    facts = page.locator("#facts")
    expect(facts).to_contain_text("hexapod_other")
    expect(facts).to_contain_text("lost front_left")
    with server.client("alice") as c:
        held = c.get(f"/api/jobs/{job_id}").json()["summary"]["robustness"]["held_out"]
    assert held["n"] == 3 and len(held["models"]) == 3, held
    with server.client("alice") as c:
        control = c.get(f"/api/jobs/{job_id}").json()["summary"]["control"]
    assert control["mode"] == "closed_loop" and control["law"]["balance_gain"] == 1.0, control["law"]
    assert control["open_loop"]["held_out"]["n"] == 3  # the same gait without the correction, same models
    expect(page.locator("#verdict-robustness .held-out")).to_contain_text(re.compile(r"\b3 held-out random models"))
    page.goto(f"{server.url}/")
    row = page.locator(f'#jobs-body tr[data-id="{job_id}"]')
    expect(row.locator('td[data-label="Robot"]')).to_have_text("hexapod_other", timeout=30_000)  # the list polls; a loaded CI machine took over 5 s

    # managed from the page: deleted (its job has ended), gone from the list and the API
    page.goto(f"{server.url}/robots/new")
    mine = page.locator(f'#mine-rows tr[data-id="{robot_id}"]')
    page.once("dialog", lambda d: d.accept())
    mine.get_by_role("button", name="Delete").click()
    expect(mine).to_have_count(0)
    with server.client("alice") as c:
        assert c.get(f"/api/robots/{robot_id}").status_code == 404


def test_the_leg_map_fits_a_phone(new_page, server, shots, tmp_path):
    """At 390 px the leg map table was 590 px wide: its caption cut mid-sentence, the joints
    and the foot behind a sideways scroll, the selects squeezed. On a phone each leg is one
    block with its fields labelled; on a desktop it stays the table with its column heads."""
    model = _model(tmp_path)
    phone = new_page(viewport=glance.PHONE)
    _check(phone, server, model)
    table = phone.locator(".legmap-table")
    expect(phone.locator("#lm-side-0")).to_be_visible()
    card = phone.locator("#legs-card").bounding_box()
    for sel in (".legmap-table caption", "#lm-side-0", "#lm-name-0", "#lm-order-0", "#lm-joints-0",
                ".legmap-table tr[data-leg='0'] td:last-child"):
        box = phone.locator(sel).first.bounding_box()
        assert box["x"] >= card["x"] and box["x"] + box["width"] <= card["x"] + card["width"] + 0.5, (sel, box, card)
    assert table.evaluate("t => t.parentElement.scrollWidth <= t.parentElement.clientWidth")  # no sideways scroll
    assert phone.locator("#lm-side-0").bounding_box()["width"] >= 70  # a select one reads, not squeezed
    expect(phone.locator("label[for='lm-side-0']")).to_be_visible()  # the field says what it is
    phone.locator("#legs-card").screenshot(path=shots / "robot-legmap-390.png")
    glance.fits_width(phone)
    desk = new_page()
    _check(desk, server, model)
    expect(desk.locator(".legmap-table thead")).to_be_visible()
    assert desk.locator("label[for='lm-side-0']").bounding_box()["width"] <= 1  # the column head says it

"""The kind contract's last promise, in a real browser: the contract tests' own kind
(tests/kinds/ballistic.py), registered only through GAITMEND_EXTRA_KINDS on the server's
process, is submitted through the dashboard's form (fields from its schema), run by the
embedded worker, and shown on the job page from what the kind supplies: its headline
("distance error", lower is better), its table, the convergence of its history, its bundle
figure, each bundle member on its own, the replay, the whole bundle, and the jobs list's
damage text. Nothing in app/ or web/ names it."""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import pytest
from playwright.sync_api import expect

import glance
from service_support import deployment, migrated

from tests.e2e.conftest import serve
from tests.e2e.test_kinds import open_group, open_kind, replay_drawn, submit, wait_done

KINDS_DIR = str(Path(__file__).resolve().parents[1] / "kinds")
EXTRA = {"GAITMEND_EXTRA_KINDS": "ballistic:KIND"}


def _pythonpath() -> str:
    return os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), KINDS_DIR) if p)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`gaitmend serve` (tokens on, embedded worker) whose process alone registers the
    ballistic kind: this module's page / new_page fixtures talk to it."""
    tmp = tmp_path_factory.mktemp("e2e-extra-kind")
    env = deployment(tmp, auth="on", lease_s=30, redispatch_after_s=120) | EXTRA | {"PYTHONPATH": _pythonpath()}
    settings = migrated({k: v for k, v in env.items() if k.startswith("GAITMEND_") and k != "GAITMEND_EXTRA_KINDS"})
    yield from serve(tmp, env, settings, ("alice",))


def test_a_kind_registered_outside_app_through_the_dashboard(page, new_page, server, shots):
    # the form: the kind is offered, its fields come from its schema, its robot is fixed
    open_kind(page, server, "ballistic")
    expect(page.locator("#kind-desc")).to_contain_text("Ball launched to a target distance")
    expect(page.locator("#robot")).to_have_value("ball")
    expect(page.locator("#robot")).to_be_disabled()
    expect(page.locator("#damage-picker")).to_be_hidden()  # no legs to draw
    page.fill("#f-target-m", "1.5")
    open_group(page, "search")
    page.fill("#f-search-generations", "2")
    page.fill("#f-search-seed", "9")
    expect(page.locator("#budget")).to_contain_text("Budget: 19 evaluations (population x (generations + 1) launches")
    with page.expect_request(lambda r: r.url.endswith("/api/jobs") and r.method == "POST") as req:
        job_id = submit(page)
    # an input left at its default is left out of the spec
    assert req.value.post_data_json == {"kind": "ballistic", "target_m": 1.5, "search": {"generations": 2, "seed": 9}}

    # the job page: the kind's headline, its history's meaning, its table, figure and files
    jp = new_page()
    wait_done(server, jp, job_id)
    with server.client() as c:
        job = c.get(f"/api/jobs/{job_id}").json()
        v = c.get(f"/api/jobs/{job_id}/views").json()
    assert job["damage"] == "target 1.5 m" and job["robot"] == "ball"
    expect(jp.locator("#job-title")).to_contain_text("ballistic job")
    expect(jp.locator("#facts")).to_contain_text("target 1.5 m")
    head = jp.locator("#headline tbody tr")
    expect(head).to_have_count(2)
    err = head.filter(has_text="distance error")
    e = job["summary"]["best"]["error_m"]
    shown = err.locator("td").nth(0).inner_text()
    assert shown.endswith(" m") and float(shown.removesuffix(" m")) == pytest.approx(e, abs=0.006), (shown, e)
    expect(err.locator("td").nth(1)).to_have_text("lower")
    expect(err).to_contain_text("<= 0.05 m")
    expect(err).to_have_attribute("data-met", "true" if e <= 0.05 else "false")
    expect(head.filter(has_text="rest position")).to_contain_text(" m")

    # convergence: the kind's history columns say what the objective is, one point per generation
    conv = jp.locator("#plot-convergence")
    expect(conv.locator(".main-svg").first).to_be_visible(timeout=30_000)
    assert jp.evaluate("document.getElementById('plot-convergence').data[0].x") == [0, 1, 2]
    ylab = jp.evaluate("document.getElementById('plot-convergence').layout.yaxis.title.text")
    assert ylab.startswith("smallest distance error so far (m)"), ylab

    # the kind's summary table as a panel
    table = jp.locator('#panels section[data-panel="table-0"]')
    expect(table.locator("h2")).to_have_text("ball to 1.5 m")
    expect(table).to_contain_text("stopped: generations")
    expect(table.locator("tbody tr")).to_have_count(1)
    expect(table.locator("thead th")).to_have_text(["vx (m/s)", "vz (m/s)", "rests at (m)", "error (m)"])

    # the bundle's own figure (the kind writes SVG only): drawn, not a broken image
    expect(jp.locator("#figures-card")).to_be_visible()
    fig = jp.locator("#figures figure", has_text="convergence")
    expect(fig).to_have_count(1)
    expect(fig.locator("figcaption a")).to_have_text(["SVG"])  # only the format the kind wrote
    fig.scroll_into_view_if_needed()
    jp.wait_for_function("() => { const i = document.querySelector('#figures img');"
                         " return i && i.complete && i.naturalWidth > 100; }", timeout=15_000)

    # every bundle member on its own: the table lists them all, the SVG and the history download
    names = jp.locator("#files tbody th a.id").all_inner_texts()
    assert sorted(names) == sorted(f["path"] for f in v["files"])
    assert {"replay.viser", "plots/convergence.svg", "trajectories/best.npz", "history.csv", "result.json"} <= set(names)
    with jp.expect_download() as one:
        jp.locator("#files a.id", has_text="plots/convergence.svg").click()
    assert one.value.suggested_filename == "convergence.svg"
    assert b"<svg" in open(one.value.path(), "rb").read()
    with jp.expect_download() as one:
        jp.locator("#files a.id", has_text="history.csv").click()
    lines = open(one.value.path()).read().splitlines()
    assert lines[0].startswith("generation") and len(lines) == 4

    # the replay: the kind's one track, named as the kind names it
    expect(jp.locator("#replay-card")).to_be_visible()
    expect(jp.locator("#replay-what")).to_contain_text("best launch")
    share = replay_drawn(jp, shots, "ballistic")
    assert share > 0.01, f"the replay canvas looks blank ({share:.2%} non-background pixels)"

    jp.evaluate("window.scrollTo(0, 0)")
    glance.page_shot(jp, shots / "ballistic-job-1280.png")

    # the whole bundle, fetched with the token
    with jp.expect_download() as dl:
        jp.click("#download")
    assert dl.value.suggested_filename == f"gaitmend-{job_id}.zip"
    with zipfile.ZipFile(dl.value.path()) as z:
        assert json.loads(z.read("manifest.json"))["kind"] == "ballistic"
        assert json.loads(z.read("result.json"))["best"] == job["summary"]["best"]
        assert {"plots/convergence.svg", "trajectories/best.npz", "replay.viser"} <= set(z.namelist())

    # the jobs list: kind, robot, the kind's damage text and its first headline row
    page.goto(server.url + "/")
    row = page.locator(f'#jobs-body tr[data-id="{job_id}"]')
    expect(row).to_have_attribute("data-status", "succeeded", timeout=30_000)
    expect(row.locator('td[data-label="Kind"]')).to_have_text("ballistic")
    expect(row.locator('td[data-label="Robot"]')).to_have_text("ball")
    expect(row.locator('td[data-label="Damage"]')).to_have_text("target 1.5 m")
    expect(row.locator("td.result")).to_contain_text("distance error: ")
    expect(row.locator("td.result")).to_contain_text(" m")
    page.screenshot(path=shots / "ballistic-jobs-1280.png")

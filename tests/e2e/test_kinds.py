"""Every kind end to end in a real browser: submitted through the dashboard's form (fields
generated from the kind's JSON schema, tiny budgets), run by the real worker, and its page
showing the kind's own science: the tipping page's margin plot with the threshold, the
multigait page's map with the tree and the plan. Then the compare page across kinds."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

import glance

JOB_TIMEOUT_MS = 180_000
DONE: dict[str, str] = {}  # kind -> job id, for the compare test


def open_kind(page, server, kind):
    page.goto(server.url + "/")
    expect(page.locator(f'#kind option[value="{kind}"]')).to_be_attached()
    page.select_option("#kind", kind)
    expect(page.locator("#spec-fields [data-field]").first).to_be_attached()


def open_group(page, path):
    box = page.locator(f'#spec-fields details[data-path="{path}"]')
    if box.count() and not box.evaluate("d => d.open"):
        box.locator("> summary").click()


def submit(page) -> str:
    page.click("#submit")
    ok = page.locator("#form-ok")
    expect(ok).to_be_visible(timeout=30_000)
    return ok.locator("a").get_attribute("href").rsplit("/", 1)[1]


def replay_drawn(jp, shots, name) -> float:
    """The 3D replay's share of drawn pixels, once it draws; the card's screenshot is kept."""
    share = glance.canvas_drawn(jp, "#replay", enough=0.05, rounds=40, every_ms=1000)
    jp.locator("#replay-card").screenshot(path=shots / f"{name}-replay-1280.png")
    return share


def wait_done(server, page, job_id):
    page.goto(f"{server.url}/jobs/{job_id}")
    expect(page.locator("#status-line .badge")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)


def test_tipping_form_error_names_the_field(page, server):
    """A bad number in a generated field: the API's message inline at that field, the group
    opened, focus on it, nothing queued."""
    open_kind(page, server, "tipping")
    open_group(page, "sweep")
    page.check("#f-sweep-enabled")
    page.fill("#f-sweep-directions", "0")
    page.click("#submit")
    err = page.locator("#form-error")
    expect(err).to_contain_text("sweep.directions")
    field = page.locator("#f-sweep-directions")
    expect(field).to_have_attribute("aria-invalid", "true")
    expect(page.locator("#f-sweep-directions-err")).to_contain_text("greater than or equal to 1")
    assert page.evaluate("document.activeElement.id") == "f-sweep-directions"
    expect(page.locator("#form-ok")).to_be_hidden()


def test_tipping_through_the_form(page, new_page, server, shots):
    open_kind(page, server, "tipping")
    expect(page.locator("#robot")).to_have_value("heavy_hexapod")
    # scenario: tilting platform, the paper's y axis counter-clockwise (climbing), stance 1 3 5
    page.select_option("#f-scenario-type", "tilt")
    page.select_option("#f-scenario-axis", "y")
    page.select_option("#f-scenario-direction", "ccw")
    page.fill("#f-scenario-stance", "1, 3, 5")
    expect(page.locator("#f-recovery-enabled")).to_be_checked()
    open_group(page, "sim")
    page.fill("#f-sim-duration-s", "14")
    # the controls and robustness re-runs stay on (the verdict reads them: 10 more runs); the
    # band search (many more) is switched off to keep the browser test short
    open_group(page, "evidence")
    page.uncheck("#f-evidence-band")
    expect(page.locator("#budget")).to_contain_text("Budget: 12 evaluations")
    with page.expect_request(lambda r: r.url.endswith("/api/jobs") and r.method == "POST") as req:
        job_id = submit(page)
    sent = req.value.post_data_json
    # the stance field starts at its default (1, 3, 5), and a field left at its default is
    # left out of the spec: the server fills it in
    assert sent["kind"] == "tipping" and sent["scenario"] == {"type": "tilt", "axis": "y", "direction": "ccw"}
    assert sent["sim"] == {"duration_s": 14}
    assert sent["evidence"] == {"band": False}
    jp = new_page()
    wait_done(server, jp, job_id)
    with server.client() as c:
        summary = c.get(f"/api/jobs/{job_id}").json()["summary"]
    thr = summary["threshold_deg"]

    # the margin plot: FASM with and without recovery, the threshold line, detection marked
    margin = jp.locator("#plot-margin")
    expect(margin.locator(".main-svg").first).to_be_visible(timeout=30_000)
    names = jp.evaluate("document.getElementById('plot-margin').data.map(t => t.name)")
    assert "FASM with recovery" in names and "FASM without recovery" in names, names
    assert f"threshold {thr:g}°" in names
    thr_trace = jp.evaluate("document.getElementById('plot-margin').data.find(t => t.name.startsWith('threshold')).y")
    assert thr_trace == [thr, thr]
    assert jp.evaluate("document.getElementById('plot-margin').layout.yaxis.title.text") == "FASM margin (°)"
    notes = jp.evaluate("document.getElementById('plot-margin').layout.annotations.map(a => a.text)")
    if summary["runs"]["recovery"].get("detection_time_s") is not None:
        assert any(n.startswith("detected") for n in notes), notes
        assert any("lands" in n for n in notes), notes
    # SSM / NESM are there on request (legend), hidden at first
    hidden = jp.evaluate("document.getElementById('plot-margin').data.filter(t => t.visible === 'legendonly').map(t => t.name)")
    assert any(n.startswith("SSM") for n in hidden) and any(n.startswith("NESM") for n in hidden)
    # beneath it, the critical support edge of each run in a row of its own (Table II's names,
    # a category axis), the shared time axis along the page's bottom
    lay = jp.evaluate("(({yaxis3, xaxis}) => ({edge: yaxis3.type, pos: xaxis.position}))(document.getElementById('plot-margin').layout)")
    assert lay == {"edge": "category", "pos": 0}, lay
    edges = jp.evaluate("document.getElementById('plot-margin').data.filter(t => t.yaxis === 'y3').flatMap(t => t.y)")
    assert edges and {e[0] for e in edges} == {"a"} and all(len(e) == 3 and set(e[1:]) <= set("123456") for e in edges), edges

    # the headline is the kind's: every row it gives is on the page (chosen leg, foothold,
    # time to tip, margins when a leg was caught), booleans in words
    with server.client() as c:
        rows = c.get(f"/api/jobs/{job_id}/views").json()["headline"]
    head = jp.locator("#headline")
    for r in rows:
        expect(head).to_contain_text(r["label"])
    if summary.get("adjustment_leg") is not None:
        expect(head).to_contain_text("adjustment leg")
        expect(head).to_contain_text("time to tip")
        expect(head).to_contain_text("margin after landing")
    expect(head).not_to_contain_text("true")
    # foot forces per leg, legs 1..6
    forces = jp.evaluate("document.getElementById('plot-forces').data.filter(t => t.showlegend !== false).map(t => t.name)")
    assert forces == [f"leg {i}" for i in range(1, 7)]
    # no kind-blind plot of raw signals (platform_tilt_deg first) any more
    assert jp.locator("#other-select").count() == 0
    jp.locator("#panel-margin").scroll_into_view_if_needed()
    jp.locator("#panel-margin").screenshot(path=shots / "tipping-margin-1280.png")
    assert replay_drawn(jp, shots, "tipping") > 0.05
    # the verdict: stays upright (its list headline), beats the run without recovery
    v = glance.check_verdict(jp, server, job_id)
    assert next(c for c in v["controls"] if c["name"] == "no_recovery")["outcome"] in ("beat", "tied")
    assert v["primary"]["label"] == "stays upright with recovery"
    glance.check_list_row(jp, server, job_id)
    glance.job_page_everywhere(new_page, server, job_id, "tipping", shots)
    DONE["tipping"] = job_id


def test_multigait_through_the_form(page, new_page, server, shots):
    open_kind(page, server, "multigait")
    expect(page.locator("#robot")).to_have_value("lizard")
    page.fill("#f-damage-stuck-modules", "1")
    page.select_option("#f-cost", "coverage")
    page.select_option("#f-map", "column")  # a select: the schema lists the maps
    open_group(page, "search")
    page.fill("#f-search-particles", "4")
    page.fill("#f-search-generations", "2")
    for group in ("planner", "reuse", "verify", "controls"):
        open_group(page, group)
    page.fill("#f-controls-heldout-plans", "4")  # the held-out draws the verdict's interval is over
    page.fill("#f-planner-iterations", "30")
    page.fill("#f-reuse-plans", "2")
    page.fill("#f-reuse-iterations", "20")
    page.fill("#f-verify-nodes", "10")
    page.fill("#f-gait-duration-s", "5")
    expect(page.locator("#budget")).to_contain_text("Budget:")
    with page.expect_request(lambda r: r.url.endswith("/api/jobs") and r.method == "POST") as req:
        job_id = submit(page)
    sent = req.value.post_data_json
    assert sent["kind"] == "multigait" and sent["damage"] == {"stuck_modules": [1]} and sent["map"] == "column"
    assert sent["search"] == {"particles": 4, "generations": 2}
    jp = new_page()
    wait_done(server, jp, job_id)

    # the map with obstacles, start, the tree coloured by gait and the final plan
    m = jp.locator("#plot-map")
    expect(m.locator(".main-svg").first).to_be_visible(timeout=30_000)
    names = jp.evaluate("document.getElementById('plot-map').data.map(t => t.name)")
    assert any(n.startswith("tree: gait") for n in names), names
    assert any(n.startswith("plan (") for n in names), names
    assert "start" in names and any(n.startswith("tree nodes") for n in names)
    plan = jp.evaluate("document.getElementById('plot-map').data.find(t => t.name.startsWith('plan (')).x.length")
    assert plan >= 2
    assert jp.evaluate("document.getElementById('plot-map').layout.yaxis.scaleanchor") == "x"  # a map, not a chart
    # coverage in percent, higher is better, as the headline and on the convergence axis;
    # never "Fitness F (higher is better)" over it
    head = jp.locator("#headline tbody tr").first
    expect(head).to_contain_text("coverage")
    expect(head).to_contain_text("%")
    expect(head).to_contain_text("higher")
    ylab = jp.evaluate("document.getElementById('plot-convergence').layout.yaxis.title.text")
    assert ylab.startswith("coverage") and "higher better" in ylab and "F" not in ylab.split("(")[0], ylab
    expect(jp.locator("body")).not_to_contain_text("Fitness F (higher is better)")
    # no non-time column against time: every x axis title of every figure is time only where it is time
    xt = jp.evaluate("""[...document.querySelectorAll('.plot')].filter(d => d.layout).map(d => [d.id,
        Object.keys(d.layout).filter(k => k.startsWith('xaxis')).map(k => (d.layout[k].title || {}).text)])""")
    comp = dict(xt).get("plot-composition")
    if comp is not None:
        assert comp[0].startswith("node depth"), comp
    expect(jp.locator("#panel-per-gait table tbody tr")).to_have_count(3)
    expect(jp.locator("#panel-reuse-table")).to_contain_text("column opposite")
    # the column map's obstacle is drawn
    assert jp.evaluate("document.getElementById('plot-map').layout.shapes.filter(s => s.fillcolor === '#374151').length") >= 1
    jp.locator("#panel-map").scroll_into_view_if_needed()
    jp.locator("#panel-map").screenshot(path=shots / "multigait-map-1280.png")
    assert replay_drawn(jp, shots, "multigait") > 0.05
    # the verdict: no target of its own; held-out coverage against the random search, with
    # the 95 % interval over the held-out draws
    v = glance.check_verdict(jp, server, job_id)
    rnd = next(c for c in v["controls"] if c["name"] == "random_search")
    assert rnd["compared"] and rnd["unit"] == "%" and rnd["seeds"] == 4 and len(rnd["interval"]) == 2, rnd
    assert v["primary"]["label"] == "coverage of the map"
    glance.check_list_row(jp, server, job_id)
    glance.job_page_everywhere(new_page, server, job_id, "multigait", shots)
    DONE["multigait"] = job_id


def test_compare_separates_kinds(page, new_page, server, shots, second_job):
    if len(DONE) < 2:
        pytest.fail("needs the tipping and multigait jobs of the tests above")
    ids = [second_job, DONE["multigait"], DONE["tipping"]]
    page.goto(f"{server.url}/compare?ids={','.join(ids)}")
    expect(page.locator("#groups section[data-group]")).to_have_count(3, timeout=30_000)
    expect(page.locator("#separated")).to_contain_text("3 groups")
    # jobs are named by kind and damage, not by 8-character ids alone
    expect(page.locator("#picked")).to_contain_text("multigait · stuck modules 1")
    expect(page.locator("#picked")).to_contain_text("recovery · lost 1,6")
    titles = page.locator("#groups h2").all_inner_texts()
    assert any(t.startswith("multigait jobs: coverage") for t in titles), titles
    assert any(t.startswith("recovery jobs: fitness F") for t in titles), titles
    # one axis per meaning: each plot holds the lines of one kind only; the tipping group
    # (a history of runs, no objective) has no plot at all
    expect(page.locator('[id^="plot-compare-"][data-rendered="1"]')).to_have_count(2, timeout=30_000)
    kinds = page.evaluate("""[...document.querySelectorAll('[id^="plot-compare-"]')].map(d =>
        [...new Set(d.data.map(t => t.name.split(' · ')[0]))])""")
    assert sorted(k for ks in kinds for k in ks) == ["multigait", "recovery"] and all(len(ks) == 1 for ks in kinds), kinds
    glance.page_shot(page, shots / "compare-kinds-1280.png")
    glance.no_axe_faults(page, "compare page")
    phone = new_page(viewport=glance.PHONE)  # opened at a phone's width (plots size to it as they draw)
    phone.goto(page.url)
    expect(phone.locator('[id^="plot-compare-"][data-rendered="1"]')).to_have_count(2, timeout=30_000)
    glance.page_shot(phone, shots / "compare-kinds-390.png")
    glance.no_axe_faults(phone, "compare page")
    glance.fits_width(phone)


# Kinds the dashboard's code never names: their fields come from their schema, their page
# from what they supply (headline, tables, views, figures, files, verdict). Small budgets;
# the evidence runs stay on (the verdict reads them). The list headline each shows.
NEWER = {
    "freegait": ({"route": ["distance-m"]}, {"#f-route-distance-m": "0.3"}, (), "footholds in forbidden zones"),
    "energy": ({"search": [], "physics": []}, {"#f-search-population": "4", "#f-search-generations": "1",
                                                "#f-physics-periods": "2"}, (), "CoT final (Eq. 11)"),
}


@pytest.mark.parametrize("kind", sorted(NEWER))
def test_newer_kind_through_the_form(kind, page, new_page, server, shots):
    from app.jobs.registry import KINDS

    assert kind in KINDS, f"{kind} is not registered"  # both are; a skip would hide losing one
    groups, fills, evidence, listed = NEWER[kind]
    open_kind(page, server, kind)
    for g in list(groups) + ["evidence"]:
        open_group(page, g)
    for sel, value in fills.items():
        page.fill(sel, value)
    for box in evidence:
        page.uncheck(f"#f-evidence-{box}")
    expect(page.locator("#budget")).to_contain_text("Budget:")
    job_id = submit(page)
    jp = new_page()
    wait_done(server, jp, job_id)
    with server.client() as c:
        v = c.get(f"/api/jobs/{job_id}/views").json()
    head = jp.locator("#headline")
    for r in v["headline"]:
        expect(head).to_contain_text(r["label"])
    figs = [p for p in v["panels"] if "figure" in p]
    assert figs, "the kind supplies at least one figure"
    first = jp.locator(f"#plot-{figs[0]['id']} .main-svg").first
    expect(first).to_be_visible(timeout=30_000)
    expect(jp.locator("#files tbody tr")).to_have_count(len(v["files"]) + 1)
    expect(jp.locator("#figures img").first).to_be_attached()
    v = glance.check_verdict(jp, server, job_id)
    assert v["primary"]["label"] == listed, v["primary"]
    # the replay frames the robot from the first step to the last
    shares = glance.replay_frames(jp, shots, kind, server, job_id)
    assert min(shares) > 0.02, shares
    glance.check_list_row(jp, server, job_id)
    glance.job_page_everywhere(new_page, server, job_id, kind, shots)
    DONE[kind] = job_id

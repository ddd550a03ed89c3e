"""The studies pages in a real headless Chromium: the list links to the study, whose page
shows progress, the aggregate table, the per-metric plot and every point's job link, and
cancels the rest."""

from __future__ import annotations

import time

from playwright.sync_api import expect

import glance

TINY = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
        "search": {"population": 4, "generations": 1, "seed": 0}, "sim": {"duration_s": 0.5}}


def test_study_list_page_and_cancel(page, server):
    study = {"name": "e2e seeds", "base": TINY, "grid": {"search.seed": [0, 1, 2]},
             "report": {"group_by": ["damage.lost_legs"], "metrics": ["best.fitness"]}}
    with server.client("alice") as c:
        r = c.post("/api/studies", json=study)
        assert r.status_code == 201, r.text
        sid = r.json()["id"]
        for _ in range(240):  # let the three tiny points finish: the page then draws their plots
            if c.get(f"/api/studies/{sid}").json()["status"] not in ("queued", "running"):
                break
            time.sleep(0.5)
    page.goto(f"{server.url}/studies")
    page.get_by_role("link", name="e2e seeds").click()
    page.wait_for_url(f"**/studies/{sid}")
    page.locator("#panel-aggregate tbody tr").first.wait_for()
    assert page.locator("#panel-aggregate tbody tr").count() == 1
    # metric paths read as names (best.fitness: "best fitness"), groups as values (no JSON, no null)
    assert page.locator("#panel-aggregate thead").inner_text().count("best fitness") == 1
    assert "null" not in page.locator("main").inner_text()
    assert page.locator("ul.points li a[href^='/jobs/']").count() == 3
    page.locator("#panel-metric-0 .plot[data-rendered='1'] .main-svg").first.wait_for()  # plotly drew it
    assert page.locator("#panel-metric-0 h2").inner_text() == "best fitness"
    if page.get_by_role("button", name="Cancel unfinished points").count():
        page.get_by_role("button", name="Cancel unfinished points").click()
    with server.client("alice") as c:
        c.post(f"/api/studies/{sid}/cancel")
        st = c.get(f"/api/studies/{sid}").json()
        assert st["spec"]["name"] == "e2e seeds"
    # a cancel after every point finished cancelled nothing: the page says what is true
    assert st["progress"]["done"] == 3 and st["status"] == "succeeded", st
    page.reload()
    line = page.locator("#st-body > p").first
    expect(line).to_contain_text("3 of 3 done")
    expect(line.locator(".badge")).to_have_text("succeeded")
    expect(line).not_to_contain_text("cancelled")


def test_builtin_select_lists_every_kinds_studies_and_submits_the_chosen_one(page, server):
    """The page names no built-in study: its select is filled from GET /api/studies/builtin,
    and Submit posts the chosen study's spec (the POST is answered here: no study runs)."""
    with server.client("alice") as c:
        items = c.get("/api/studies/builtin").json()["items"]
        chosen = items[-1]["name"]
        spec = c.get(f"/api/studies/builtin/{chosen}").json()
    assert len({i["kind"] for i in items}) >= 2
    posted = []

    def answer(route):
        if route.request.method != "POST":
            return route.continue_()
        posted.append(route.request.post_data_json)
        route.fulfill(status=201, json={"id": "0123abcd"})

    page.route("**/api/studies", answer)
    page.goto(f"{server.url}/studies")
    page.locator("#builtin-form button[type=submit]:not([disabled])").wait_for()
    options = page.locator("#builtin option")
    assert options.evaluate_all("os => os.map((o) => o.value)") == [i["name"] for i in items]
    assert options.evaluate_all("os => os.map((o) => o.title)") == [i["title"] for i in items]
    page.select_option("#builtin", chosen)
    page.get_by_role("button", name="Check and submit").click()
    # nothing is queued before the size and the time are shown and confirmed
    expect(page.locator("#st-confirm")).to_be_visible()
    expect(page.locator("#st-estimate")).to_contain_text("evaluations in all")
    assert posted == []
    page.get_by_role("button", name="Submit the study").click()
    page.wait_for_url("**/studies/0123abcd")
    assert posted == [spec]


def test_a_custom_study_without_metrics_reports_the_kinds_headline(page, new_page, server, shots):
    """The custom-study form: a base job from the kind's form, a grid of seeds, no metrics
    named; its size and time are checked first, and the study reports the kind's headline
    (recovery: the forward distance, in cm) with the verdict pooled over the seeds."""
    page.goto(f"{server.url}/studies")
    expect(page.locator("#st-kind option")).not_to_have_count(0)
    glance.page_shot(page, shots / "studies-1280.png")
    glance.no_axe_faults(page, "studies list")
    # a list draws no plot: plotly.min.js is never fetched
    assert not page.evaluate("performance.getEntriesByType('resource').some(r => r.name.includes('plotly'))")
    page.locator("#custom > summary").click()
    page.fill("#st-name", "e2e headline")
    page.select_option("#st-kind", "recovery")
    for group in ("search", "sim"):
        box = page.locator(f'#st-base details[data-path="{group}"]')
        if not box.evaluate("d => d.open"):
            box.locator("> summary").click()
    page.fill("#st-base #f-search-population", "4")
    page.fill("#st-base #f-search-generations", "1")
    page.fill("#st-base #f-sim-duration-s", "0.5")
    expect(page.locator("#grid-values-0")).to_have_value("0, 1, 2")
    page.fill("#grid-values-0", "0, 1")
    page.click("#custom-check")
    expect(page.locator("#st-estimate")).to_contain_text("2 jobs")
    glance.no_axe_faults(page, "studies list (custom form open)")
    page.click("#custom-submit")
    expect(page.locator("#st-confirm, #panel-aggregate").first).to_be_visible(timeout=30_000)
    if page.locator("#st-confirm").is_visible():
        page.click("#st-confirm-yes")
    page.wait_for_url("**/studies/*")
    sid = page.url.rstrip("/").rsplit("/", 1)[1]
    with server.client("alice") as c:
        st = c.get(f"/api/studies/{sid}").json()
        assert st["spec"]["report"]["metrics"] == ["headline.primary"]
        for _ in range(240):
            if c.get(f"/api/studies/{sid}").json()["status"] not in ("queued", "running"):
                break
            time.sleep(0.5)
        agg = c.get(f"/api/studies/{sid}").json()["aggregate"]
    assert agg["rows"][0]["metrics"]["headline.primary"]["n"] == 2  # a number from every point
    page.reload()
    head = page.locator("#panel-aggregate thead")
    expect(head).to_contain_text("forward distance (cm)")
    expect(page.locator("#panel-verdict")).to_contain_text("uniform random search")
    # 0.5 s walks: recovery's target (rates over the walk) needs 3 s, so the points are not
    # judged by it, and the page says so and why: never "no target"
    expect(page.locator("#panel-verdict")).to_contain_text("not judged")
    expect(page.locator("#panel-verdict")).to_contain_text("needs >= 3 s")
    expect(page.locator("#panel-verdict")).not_to_contain_text("no target")
    # the held-out random models over the points, a column the table sorts by (issue 46)
    held = page.locator("#panel-verdict thead th").filter(has_text="held-out models kept")
    expect(held).to_have_count(1)
    held.locator("button.sort").click()
    expect(held).to_have_attribute("aria-sort", "descending")
    held.locator("button.sort").press("Enter")
    expect(held).to_have_attribute("aria-sort", "ascending")
    expect(page.locator("#panel-metric-0 .plot[data-rendered='1']")).to_be_attached(timeout=30_000)
    assert "null" not in page.locator("main").inner_text()
    glance.page_shot(page, shots / "study-1280.png")
    glance.no_axe_faults(page, "study page")
    for path, name in ((f"/studies/{sid}", "study"), ("/studies", "studies")):
        pg = new_page(viewport=glance.PHONE)
        pg.goto(server.url + path)
        expect(pg.locator("#panel-aggregate, #study-list").first).to_be_visible(timeout=30_000)
        pg.wait_for_timeout(500)
        glance.page_shot(pg, shots / f"{name}-390.png")
        glance.no_axe_faults(pg, f"{name} page")
        glance.fits_width(pg)
        if name == "study":
            _verdict_fits_a_phone(pg)
    # the desktop keeps the verdict a table, its notes readable beside the values
    assert page.locator("#panel-verdict table").evaluate("t => getComputedStyle(t).display") == "table"


def _verdict_fits_a_phone(pg):
    """The verdict over the seeds at 390 px: no sideways scroll (its table showed 2 of 6
    columns, the rest behind an unmarked scroll, rows ~280 px tall), every cell on screen
    under its column's name."""
    table = pg.locator("#panel-verdict table")
    wrap = pg.locator("#panel-verdict .table-wrap")
    assert wrap.evaluate("w => w.scrollWidth <= w.clientWidth + 1"), \
        wrap.evaluate("w => [w.scrollWidth, w.clientWidth]")
    heads = table.locator("thead th").all_inner_texts()
    assert len(heads) == 7, heads
    right = wrap.bounding_box()["x"] + wrap.bounding_box()["width"]
    for row in table.locator("tbody tr").all():
        cells = row.locator("td")
        assert cells.evaluate_all("cs => cs.map((c) => c.dataset.label)") == heads[1:]
        for k in range(cells.count()):
            box = cells.nth(k).bounding_box()
            assert box["width"] > 0 and box["x"] + box["width"] <= right + 1, (heads[k + 1], box, right)
        # a label above its value: the column's name is on screen, not only in the head
        assert cells.first.evaluate("c => getComputedStyle(c, '::before').content") == f'"{heads[1]}"'

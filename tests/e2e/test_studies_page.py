"""The studies pages in a real headless Chromium: the list links to the study, whose page
shows progress, the aggregate table, the per-metric plot and every point's job link, and
cancels the rest."""

from __future__ import annotations

import time

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
    page.locator("#aggregate tbody tr").first.wait_for()
    assert page.locator("#aggregate tbody tr").count() == 1
    assert page.locator("#aggregate thead").inner_text().count("best.fitness") == 1
    assert page.locator("ul li a[href^='/jobs/']").count() == 3
    page.locator("#panel-metric-0 .plot[data-rendered='1'] .main-svg").first.wait_for()  # plotly drew it
    assert page.locator("#panel-metric-0 h2").inner_text() == "best.fitness"
    if page.get_by_role("button", name="Cancel unfinished points").count():
        page.get_by_role("button", name="Cancel unfinished points").click()
    with server.client("alice") as c:
        c.post(f"/api/studies/{sid}/cancel")
        assert c.get(f"/api/studies/{sid}").json()["spec"]["name"] == "e2e seeds"


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
    page.get_by_role("button", name="Submit").click()
    page.wait_for_url("**/studies/0123abcd")
    assert posted == [spec]

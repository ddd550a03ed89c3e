"""The dashboard's own routes (app/api/routes/dashboard.py) against the running server: bundle members with
owner checks, signed links for viser's playbackPath, the trace summary the plots use, and
the jobs list staying fast with thousands of jobs (keyset pages, live refresh)."""

from __future__ import annotations

import time

import httpx
from playwright.sync_api import expect

from app.results import observed

SPEC = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
        "search": {"population": 6, "generations": 2, "seed": 4}, "sim": {"duration_s": 1.5}}


def test_bundle_members_links_and_traces(server, second_job):
    jid = second_job
    with server.client("alice") as c:
        files = c.get(f"/api/jobs/{jid}/files").json()
        assert files["replay.viser"] > 1000 and "trajectories/best.csv" in files
        head = c.get(f"/api/jobs/{jid}/files/trajectories/best.csv").text.splitlines()[0]
        assert head.startswith("time_s,")
        assert c.get(f"/api/jobs/{jid}/files/nope.txt").status_code == 404
        assert c.get(f"/api/jobs/{jid}/files/..%2Fmanifest.json").status_code in (404, 422)
        link = c.get(f"/api/jobs/{jid}/file-link", params={"path": "replay.viser"}).json()

        v = c.get(f"/api/jobs/{jid}/views").json()
        assert v["kind"] == "recovery" and v["convergence"]["better"] == "higher"
        assert v["budget"]["evaluations"] > 0 and v["headline"]
        figs = {p["id"]: p for p in v["panels"] if "figure" in p}
        assert {"orientation", "com", "gait"} <= set(figs)
        gait = figs["gait"]["figure"]
        # legs as the robot numbers them (1 and 6 lost), every label shown
        assert set(gait["layout"]["yaxis"]["tickvals"]) == {
            f"{who} · leg {leg}" for who in ("recovered", "tripod") for leg in (2, 3, 4, 5)}
        assert sorted(f["path"] for f in v["files"]) == sorted(files)
        # one scene per run: the recovered gait in replay.viser (where it always was), the
        # baseline in its own member, each with its README row
        assert [(t["name"], t["path"]) for t in v["replay"]] == [("best", "replay.viser"),
                                                                  ("baseline", "replay/baseline.viser")]
        assert files["replay/baseline.viser"] > 1000
        what = {f["path"]: f["what"] for f in v["files"]}
        assert "recovered gait alone" in what["replay.viser"] and "nominal tripod alone" in what["replay/baseline.viser"]
        assert all("sig=" in f["url"] for f in v["files"])
    raw = httpx.get(server.url + link["url"])  # no Authorization header: the signature admits it
    assert raw.status_code == 200 and raw.content[:1] and len(raw.content) == files["replay.viser"]
    bad = link["url"].replace("sig=", "sig=0")
    assert httpx.get(server.url + bad).status_code == 401
    other = link["url"].replace("replay.viser", "result.json")  # the signature is for one file
    assert httpx.get(server.url + other).status_code == 401
    assert httpx.get(f"{server.url}/api/jobs/{jid}/files").status_code == 401
    with server.client("bob") as c:  # someone else's job is not found, and bob gets no link to it
        assert c.get(f"/api/jobs/{jid}/files/result.json").status_code == 404
        assert c.get(f"/api/jobs/{jid}/file-link", params={"path": "result.json"}).status_code == 404
        assert c.get(f"/api/jobs/{jid}/views").status_code == 404


def test_static_assets_come_from_installed_packages(server):
    js = httpx.get(server.url + "/vendor/plotly.min.js")
    assert js.status_code == 200 and b"plotly.js" in js.content[:200]
    viser = httpx.get(server.url + "/viser/")
    assert viser.status_code == 200 and b"Viser" in viser.content[:2000]
    for page, title, current in (("/", "jobs", "/"), ("/compare", "compare", "/compare"),
                                 ("/jobs/whatever", "job", None)):
        r = httpx.get(server.url + page)
        assert r.status_code == 200 and "text/html" in r.headers["content-type"]
        for src in ("/static/common.js", "/static/app.css"):
            assert src in r.text
        # the shared header is put in once, with this page's title and nav link marked
        assert r.text.startswith("<!doctype html>") and "gaitmend: header" not in r.text
        assert r.text.count('<header class="top">') == 1 and f"<title>gaitmend · {title}</title>" in r.text
        marked = [a for a in ('href="/"', 'href="/compare"') if f'<a {a} aria-current="page">' in r.text]
        assert marked == ([f'href="{current}"'] if current else [])
    assert httpx.get(server.url + "/static/jobs.js").status_code == 200
    # every page has one h1; the summary box scrolls by keyboard (focusable region)
    for page in ("/", "/compare", "/jobs/whatever"):
        assert httpx.get(server.url + page).text.count("<h1") == 1, page
    assert 'id="summary" tabindex="0"' in httpx.get(server.url + "/jobs/whatever").text


def test_jobs_list_stays_fast_with_thousands_of_jobs(new_page, server):
    """3000 finished jobs of one owner: the first page and every older page arrive quickly,
    and the live refresh keeps to the newest page."""
    from app.store import repo
    from app.store.db import session_scope
    from app.store.models import utcnow

    with session_scope(server.settings.db_url) as s:
        for i in range(3000):
            job = repo.create_job(s, owner="carol", kind="recovery", robot="jethexa",
                                  spec=SPEC | {"damage": {"lost_legs": [1 + i % 6]}}, evaluations_budget=18,
                                  max_attempts=3)
            job.status, job.finished_at = "cancelled", utcnow()
    pg = new_page(owner="carol")
    requests = []
    pg.on("request", lambda r: requests.append(r.url) if "/api/jobs?" in r.url else None)
    t0 = time.monotonic()
    pg.goto(server.url + "/")
    expect(pg.locator("#jobs-body tr")).to_have_count(50)
    first_page_s = time.monotonic() - t0
    t1 = time.monotonic()
    pg.click("#more")
    expect(pg.locator("#jobs-body tr")).to_have_count(150)
    older_s = time.monotonic() - t1
    print(f"\n3000 jobs: first page {first_page_s:.2f} s (page load included), older page {older_s:.2f} s")
    observed.record("dashboard.jobs_first_page_s", [first_page_s])
    observed.record("dashboard.jobs_older_page_s", [older_s])
    assert first_page_s < 10 and older_s < 5
    pg.wait_for_timeout(2500)  # a live refresh later the older rows are still there, nothing grew
    expect(pg.locator("#jobs-body tr")).to_have_count(150)
    assert all("limit=50" in u or "cursor=" in u for u in requests)
    # a filter starts again from the newest page
    pg.select_option("#f-status", "succeeded")
    expect(pg.locator("#jobs-count")).to_contain_text("No jobs match")
    pg.select_option("#f-status", "cancelled")
    expect(pg.locator("#jobs-body tr")).to_have_count(50)


def test_kinds_and_check_for_the_form(server):
    """The form is built from every registered kind's schema; a check gives the spec's own
    budget, or the API's field errors, and queues nothing."""
    from app.jobs.registry import KINDS

    with server.client("alice") as c:
        kinds = c.get("/api/web/kinds").json()
        assert [k["name"] for k in kinds] == list(KINDS)
        for k in kinds:
            assert k["schema"]["properties"]["kind"]["const"] == k["name"] and k["title"]
        before = c.get("/api/jobs", params={"limit": 500}).json()["items"]
        ok = c.post("/api/web/check", json=SPEC).json()
        assert ok["evaluations"] == KINDS["recovery"].Spec.parse(SPEC).evaluations_budget
        bad = c.post("/api/web/check", json=SPEC | {"search": {"population": 2}})
        assert bad.status_code == 422 and bad.json()["errors"][0]["field"] == "search.population"
        assert c.post("/api/web/check", json={"kind": "nope"}).json()["errors"][0]["field"] == "kind"
        assert c.get("/api/jobs", params={"limit": 500}).json()["items"] == before
    assert httpx.post(server.url + "/api/web/check", json=SPEC).status_code == 401  # tokens on


def test_plotly_goes_compressed_and_pages_are_cached(server):
    """plotly.min.js over the wire gzipped (measured: the bytes of the body as sent), under a
    versioned URL cached for a year; static files named with their content hash likewise;
    a page's HTML and the API's JSON compressed by the middleware."""
    import re as _re

    page = httpx.get(server.url + "/jobs/whatever").text
    url = _re.search(r'<meta name="gm-plotly" content="([^"]+)"', page).group(1)
    assert "?v=" in url
    with httpx.Client(base_url=server.url) as c:
        with c.stream("GET", url, headers={"Accept-Encoding": "gzip"}) as r:
            wire = sum(len(b) for b in r.iter_raw())
            assert r.headers["content-encoding"] == "gzip" and "immutable" in r.headers["cache-control"]
        plain = len(c.get(url, headers={"Accept-Encoding": "identity"}).content)
    print(f"\nplotly.min.js: {wire} bytes over the wire gzipped, {plain} bytes uncompressed")
    observed.record("dashboard.plotly_full_bytes", [plain])
    observed.record("dashboard.plotly_full_gzip_bytes", [wire])
    assert wire < plain / 2.5
    js = _re.search(r'src="(/static/common\.js\?v=[0-9a-f]+)"', page).group(1)
    r = httpx.get(server.url + js, headers={"Accept-Encoding": "gzip"})
    assert "immutable" in r.headers["cache-control"] and r.headers.get("content-encoding") == "gzip"
    assert httpx.get(server.url + "/static/common.js").headers["cache-control"] == "no-cache"
    assert httpx.get(server.url + "/", headers={"Accept-Encoding": "gzip"}).headers.get("content-encoding") == "gzip"


def test_a_cold_job_page_draws_within_two_seconds(new_page, server, second_job):
    """A succeeded job's page in a fresh browser context (nothing cached), timed with the
    browser's timing API: navigation start to the verdict, to the first screen drawn (the
    verdict and every plot in the window), and to every plot drawn. After the verdict it is
    the page's own thread: plotly's start-up (its cartesian bundle, compiled off that thread
    as it downloads) and each plot's first draw, and under load that thread waits for a
    core: the bounds are for a loaded CI machine; the speed is in docs/dashboard.md (the
    figures this test records with GAITMEND_OBSERVED)."""
    import glance

    first = glance.cold_draw_ms(new_page, server, second_job)  # the server computes the views once per bundle
    t = glance.cold_draw_ms(new_page, server, second_job)
    assert first["first"] < 4000, first
    assert t["verdict"] < 2000 and t["first"] < 2000, t
    assert t["drawn"] < 5_000, t  # see the docstring: a loaded CI machine, not the speed
    observed.record("dashboard.cold_verdict_ms", [t["verdict"]])
    observed.record("dashboard.cold_drawn_ms", [t["drawn"]])
    observed.record("dashboard.cold_first_load_drawn_ms", [first["drawn"]])
    observed.record("dashboard.plotly_cartesian_gzip_bytes", [t["plotly"]])
    # a recovery page draws only cartesian traces: plotly's cartesian bundle, gzipped, and not the full one
    assert list(t["bundles"]) == ["plotly-cartesian.min.js"] and 0 < t["plotly"] < 700_000, t
    # ... which starts with V8's compile hint (compiled off the page's thread as it downloads)
    js = httpx.get(f"{server.url}/vendor/plotly-cartesian.min.js", headers={"Accept-Encoding": "gzip"}).content
    assert js.startswith(b"//# allFunctionsCalledOnLoad\n") and b"plotly.js" in js[:200]


def test_a_short_walk_is_not_judged_and_the_replay_waits_for_the_screen_then_switches_runs(new_page, server, second_job):
    """SECOND walks 1.5 s, under the 3 s the recovery target needs (issue 25): the verdict
    says the target was not judged (not "not met"), and so are the re-runs; viser's client
    (which plays, and renders, as soon as it loads) gets its address only once on screen,
    opens on the recovered gait alone, and a button switches it to the baseline's own scene
    and back."""
    import glance

    pg = new_page()
    requested: list[str] = []
    pg.on("request", lambda r: requested.append(r.url))
    pg.goto(f"{server.url}/jobs/{second_job}")
    expect(pg.locator("body[data-drawn='1']")).to_be_attached(timeout=60_000)
    expect(pg.locator("#verdict-target")).to_contain_text("– target not judged")
    expect(pg.locator("#verdict-target")).to_contain_text("1.5 s walk is too short to judge")
    expect(pg.locator("#verdict-robustness")).to_contain_text("not judged")
    expect(pg.locator("#headline tbody tr").filter(has=pg.locator("th", has_text="recovery target"))).to_contain_text(
        "not judged (walk too short)")
    pg.wait_for_timeout(500)
    assert pg.locator("#replay").get_attribute("src") is None
    assert not [u for u in requested if "/viser/" in u or ".viser" in u], requested
    tracks = glance.default_scene(pg, server, second_job)
    assert [t["name"] for t in tracks] == ["best", "baseline"], tracks
    pg.locator("#replay").scroll_into_view_if_needed()
    expect(pg.frame_locator("#replay").locator("canvas").first).to_be_visible(timeout=60_000)
    assert pg.locator("#replay").get_attribute("src").startswith("/viser/?playbackPath=")
    glance.switch_track(pg, tracks[1])
    assert pg.locator("#replay-file").inner_text() == "replay/baseline.viser"
    glance.switch_track(pg, tracks[0])
    glance.no_axe_faults(pg, "recovery job page with the run buttons")

"""What every page of ours is checked for beside its own test (issue 25): the verdict block
of a job page (target, the method against its controls, robustness k of n), the jobs
list's row (the kind's list headline and the verdict in brief), axe-core over our own page
(never viser's or Swagger's frames: 0 critical, 0 serious) at desktop and phone widths,
screenshots at both, and the replay framing its robot at the start, middle and end.

axe-core is vendored (tests/e2e/vendor/axe.min.js, MPL-2.0, the file's own header): the
tests load nothing from a network."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from playwright.sync_api import expect

AXE = Path(__file__).parent / "vendor" / "axe.min.js"
DESKTOP = {"width": 1280, "height": 800}
PHONE = {"width": 390, "height": 844}
AXE_RESULTS: dict[str, dict[str, int]] = {}  # "page @ width" -> counts by impact (printed at the end)


# Chromium caps a capture's height, and a capture taken while the compositor is busy can fail
# with "Unable to capture screenshot" (a CI run failed on the phone jobs list that way).
SHOT_MAX_H = 8000


def page_shot(page, path) -> bytes:
    """A full-page screenshot saved under ``path`` (an artifact, never an assertion), at most
    SHOT_MAX_H pixels tall; retried once after a frame when Chromium refuses the capture."""
    from playwright.sync_api import Error

    h = min(int(page.evaluate("document.documentElement.scrollHeight")), SHOT_MAX_H)
    clip = {"x": 0, "y": 0, "width": page.viewport_size["width"], "height": max(h, 1)}
    try:
        return page.screenshot(path=str(path), full_page=True, clip=clip)
    except Error as e:
        if "Unable to capture screenshot" not in str(e):
            raise
        page.wait_for_timeout(500)
        return page.screenshot(path=str(path), full_page=True, clip=clip)


def axe(page, name: str) -> list[dict]:
    """Runs axe-core over the page (iframes left out: the replay is viser's client), records
    the counts by impact under ``name`` and returns the critical and serious violations."""
    if not page.evaluate("typeof window.axe !== 'undefined'"):
        page.add_script_tag(content=AXE.read_text())
    res = page.evaluate("""async () => {
        const r = await axe.run({ exclude: [["iframe"]] }, { resultTypes: ["violations"] });
        return r.violations.map(v => ({ id: v.id, impact: v.impact, help: v.help,
                                         nodes: v.nodes.slice(0, 3).map(n => n.target.join(" ")) }));
    }""")
    counts = {k: sum(v["impact"] == k for v in res) for k in ("critical", "serious", "moderate", "minor")}
    AXE_RESULTS[f"{name} @ {page.viewport_size['width']}"] = counts
    print(f"\naxe {name} @ {page.viewport_size['width']} px: {json.dumps(counts)}"
          + "".join(f"\n  {v['impact']}: {v['id']} ({v['help']}) at {v['nodes']}" for v in res))
    return [v for v in res if v["impact"] in ("critical", "serious")]


def no_axe_faults(page, name: str) -> None:
    bad = axe(page, name)
    assert not bad, f"axe on {name} at {page.viewport_size['width']} px: {bad}"


def fits_width(page) -> None:
    """Nothing wider than the screen (a phone never scrolls sideways)."""
    assert page.evaluate("document.documentElement.scrollWidth") <= page.viewport_size["width"] + 1


def check_verdict(jp, server, job_id: str) -> dict:
    """The verdict block at the top of a succeeded job page: the target (met or not, or the
    kind's word that it has none), every control the kind compares with its outcome and by
    how much, robustness k of n by group, all as the API's verdict says."""
    with server.client() as c:
        v = c.get(f"/api/jobs/{job_id}/views").json()["verdict"]
    box = jp.locator("#verdict")
    expect(box).to_be_visible(timeout=30_000)
    # at the top: above the headline table and every plot
    assert jp.evaluate("document.getElementById('verdict').getBoundingClientRect().top") < \
        jp.evaluate("document.getElementById('headline-card').getBoundingClientRect().top")
    target = jp.locator("#verdict-target")
    met = v["target"]["met"]
    expect(target).to_contain_text("✓ target met" if met is True else "✗ target not met" if met is False
                                   else re.compile("no target of its own|target not judged"))
    if v["target"]["text"]:
        expect(target).to_contain_text(v["target"]["text"][:40])
    compared = [c for c in v["controls"] if c["compared"]]
    assert compared, f"the verdict compares the method with no control: {v['controls']}"
    for c in compared:
        li = jp.locator(f'#verdict-controls li[data-control="{c["name"]}"]')
        expect(li).to_have_attribute("data-outcome", c["outcome"])
        expect(li).to_contain_text(c["outcome"])
        if c["by"] is not None and c["outcome"] != "tied":
            expect(li).to_contain_text(" by ")  # by how much, in the kind's unit
    rob = v["robustness"]
    assert rob, "the verdict has no robustness block"
    expect(jp.locator("#verdict-robustness")).to_contain_text(f"{rob['met']} of {rob['total']}")
    for g in rob["groups"]:
        expect(jp.locator(f'#verdict-robustness li[data-group="{g["name"]}"]')).to_contain_text(f"{g['met']} of {g['total']}")
    return v


def check_list_row(page, server, job_id: str) -> None:
    """The jobs list's row of a succeeded job shows the kind's list headline (label, value
    and unit) and the verdict in brief, with seed and budget."""
    with server.client() as c:
        row = c.get("/api/web/rows", params={"ids": job_id}).json()[job_id]
    page.goto(server.url + "/")
    tr = page.locator(f'#jobs-body tr[data-id="{job_id}"]')
    expect(tr).to_be_visible(timeout=30_000)
    head = row["headline"]
    cell = tr.locator("td.result")
    expect(cell).to_contain_text(f"{head['label']}: ")
    if head["unit"]:
        expect(cell).to_contain_text(head["unit"])
    if row["verdict"]["robustness"]:
        expect(cell).to_contain_text(f"robust {row['verdict']['robustness'][0]}/{row['verdict']['robustness'][1]}")
    held = row["verdict"].get("held_out")
    if held:  # the held-out random models, before the re-runs (issue 46)
        kept = f"{held['met']}/{held['judged']}" if held["judged"] else f"{held['n']} not judged"
        expect(cell.locator(".held-out")).to_contain_text(f"held-out {kept}")
    expect(tr.locator("td.run")).to_contain_text(f"{row['budget']} evals")
    if row["seed"] is not None:
        expect(tr.locator("td.run")).to_contain_text(f"seed {row['seed']}")


def job_page_everywhere(new_page, server, job_id: str, name: str, shots: Path) -> None:
    """The job page at 1280 and 390 px: screenshots, axe, nothing wider than a phone."""
    for vp, tag in ((DESKTOP, "1280"), (PHONE, "390")):
        pg = new_page(viewport=vp)
        pg.goto(f"{server.url}/jobs/{job_id}")
        expect(pg.locator("body[data-drawn='1']")).to_be_attached(timeout=60_000)
        page_shot(pg, shots / f"{name}-job-{tag}.png")
        no_axe_faults(pg, f"{name} job page")
        if vp is PHONE:
            fits_width(pg)


def cold_draw_ms(new_page, server, job_id: str) -> dict[str, float]:
    """A cold job page (new browser context: empty cache) until every plot is drawn, from
    the browser's timing API: navigation start to the verdict and to the last plot.

    It waits with a plain check of the page's ``data-drawn`` every 100 ms, not with
    ``expect``: expect's retries run on the page's own thread while it loads and take an aria
    snapshot of the whole page each time one fails, which the page's marks then counted
    (about 0.1 s of its thread in a trace; the median every-plot mark was 1.41 s with it and
    1.24 s without, 10 loads each, load average 2.7-6.4)."""
    pg = new_page()
    pg.goto(f"{server.url}/jobs/{job_id}")
    pg.wait_for_function("() => document.body.dataset.drawn === '1'", polling=100, timeout=60_000)
    t = pg.evaluate("""() => ({ verdict: performance.getEntriesByName('gm-verdict')[0].startTime,
        first: performance.getEntriesByName('gm-first-screen')[0].startTime,
        plotly_ready: performance.getEntriesByName('gm-plotly')[0].startTime,
        drawn: performance.getEntriesByName('gm-drawn')[0].startTime,
        dom: performance.getEntriesByType('navigation')[0].domContentLoadedEventEnd,
        bundles: Object.fromEntries(performance.getEntriesByType('resource').filter(r => r.name.includes('/vendor/plotly'))
                   .map(r => [r.name.split('/vendor/')[1].split('?')[0], r.transferSize])) })""")
    t["plotly"] = sum(t["bundles"].values())
    print(f"\ncold job page {job_id[:8]}: DOMContentLoaded {t['dom']:.0f} ms, verdict {t['verdict']:.0f} ms, "
          f"first screen drawn {t['first']:.0f} ms, plotly ready {t['plotly_ready']:.0f} ms, every plot drawn "
          f"{t['drawn']:.0f} ms; plotly over the wire {t['bundles']} bytes")
    return t


def non_background(png: bytes) -> float:
    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int).reshape(-1, 3)
    colors, counts = np.unique(a, axis=0, return_counts=True)
    return float((np.abs(a - colors[counts.argmax()]).sum(axis=1) > 30).mean())


def canvas_drawn(page, frame: str, enough: float, rounds: int, every_ms: int) -> float:
    """Scroll to the viser client in the iframe ``frame`` and wait until its canvas shows the
    scene, not just the background: the share of non-background pixels in the middle of the
    canvas, once above ``enough`` (or the last share seen after ``rounds`` looks)."""
    page.locator(frame).scroll_into_view_if_needed()
    canvas = page.frame_locator(frame).locator("canvas").first
    expect(canvas).to_be_visible(timeout=60_000)
    share = 0.0
    for _ in range(rounds):
        page.wait_for_timeout(every_ms)
        try:  # the client lays its canvas out over a few frames in software GL (0 x 0 at first)
            bb = canvas.bounding_box(timeout=5000)  # and may swap it while the recording loads
        except PlaywrightTimeout:
            continue
        if not bb or bb["width"] < 50 or bb["height"] < 50:
            continue
        share = non_background(page.screenshot(clip={"x": bb["x"] + bb["width"] * 0.2, "y": bb["y"] + bb["height"] * 0.15,
                                                     "width": bb["width"] * 0.6, "height": bb["height"] * 0.7}))
        if share > enough:
            break
    return share


def colour_share(png: bytes, hex_colour: str) -> float:
    """Share of the picture in a run's colour (hue within ~14 degrees, saturated, not dark):
    its robot and its path, however the scene's light shades them; the ground, the sky and
    the world's own zones are other colours."""
    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV")).astype(int).reshape(-1, 3)
    want = np.asarray(Image.new("RGB", (1, 1), hex_colour).convert("HSV")).astype(int).reshape(3)
    dh = np.abs(hsv[:, 0] - want[0])
    return float(((np.minimum(dh, 256 - dh) <= 10) & (hsv[:, 1] > 90) & (hsv[:, 2] > 40)).mean())


def default_scene(jp, server, job_id: str) -> list[dict]:
    """The replay opens on the method's answer alone (the kind's first track, the bundle's
    replay.viser), with a pressed button for it among one per run when there are several;
    returns the tracks as the API lists them."""
    with server.client() as c:
        tracks = c.get(f"/api/jobs/{job_id}/views").json()["replay"]
    assert tracks and all(t["path"] for t in tracks), tracks
    assert tracks[0]["path"] == "replay.viser"
    frame = jp.locator("#replay")
    expect(frame).to_have_attribute("data-track", tracks[0]["name"], timeout=30_000)
    expect(frame).to_have_attribute("title", f"3D replay of {tracks[0]['label']}")
    buttons = jp.locator("#replay-tracks button")
    if len(tracks) > 1:
        expect(buttons).to_have_count(len(tracks))
        expect(buttons.nth(0)).to_have_attribute("aria-pressed", "true")
        expect(buttons.nth(0)).to_have_text(tracks[0]["label"])
    else:
        expect(jp.locator("#replay-tracks")).to_be_hidden()
    return tracks


def replay_frames(jp, shots: Path, name: str, server=None, job_id: str | None = None) -> list[float]:
    """The replay's canvas at the start, the middle and the end of the walk: viser's client
    plays the recording in a loop and its timeline slider says where it is (aria-valuenow of
    aria-valuemax seconds), so each screenshot is taken when the slider is in that part of
    the walk. Returns the share of the canvas that is not background in each (the robot,
    its path and the ground in view); prints the time each was taken at. With the job, the
    scene shown is the method's answer alone and its robot is in view in each (a share of
    the canvas in the run's colour; its path alone is a thin line)."""
    tracks = default_scene(jp, server, job_id) if job_id else None
    jp.locator("#replay").scroll_into_view_if_needed()
    canvas = jp.frame_locator("#replay").locator("canvas").first
    expect(canvas).to_be_visible(timeout=60_000)
    frame = next(f for f in jp.frames if "/viser/" in f.url)
    where = "() => { const s = document.querySelector('[role=slider]'); return s ? [+s.getAttribute('aria-valuenow'), +s.getAttribute('aria-valuemax')] : null; }"
    wanted = {"start": (0.0, 0.12), "middle": (0.4, 0.6), "end": (0.85, 1.0)}
    shares, at, robot = {}, {}, {}
    loops, last = 0, 0.0  # the scene streams in (the ground, then the robot's meshes): a part of the
    for _ in range(900):  # walk caught before the robot is drawn is tried again on the next loop, up to 3
        pos = frame.evaluate(where)
        if not pos or not pos[1]:
            jp.wait_for_timeout(200)
            continue
        frac = pos[0] / pos[1]
        loops, last = loops + (frac < last - 0.5), frac
        done = {t for t in robot if not tracks or robot[t] > ROBOT_IN_VIEW or loops >= 3}
        if len(done) == len(wanted):
            break
        tag = next((t for t, (lo, hi) in wanted.items() if t not in done and lo <= frac <= hi), None)
        if tag is None:
            jp.wait_for_timeout(50)
            continue
        bb = canvas.bounding_box()
        png = jp.screenshot(clip=bb, path=shots / f"{name}-replay-{tag}-1280.png")
        if bb["width"] > 50 and non_background(png) > 0.02:  # drawn (not the first blank frames)
            shares[tag], at[tag] = non_background(png), round(pos[0], 2)
            robot[tag] = colour_share(png, tracks[0]["color"]) if tracks else None
    print(f"\nreplay {name}: screenshots at {at} s of the walk; non-background share "
          f"{ {t: round(v, 3) for t, v in shares.items()} }; in the run's colour "
          f"{ {t: v if v is None else round(v, 4) for t, v in robot.items()} }")
    assert set(shares) == set(wanted), f"the replay of {name} was not caught at {set(wanted) - set(shares)}"
    if tracks:
        assert min(robot.values()) > ROBOT_IN_VIEW, f"the {name} robot is out of view at some point: {robot}"
    return [shares[t] for t in wanted]


ROBOT_IN_VIEW = 0.004  # share of the canvas in the run's colour with the robot in view (see replay_frames)


def switch_track(jp, track: dict) -> None:
    """Press a run's button: the frame plays that run's own scene (its bundle member through
    a signed link), the button is pressed and the others not, and the canvas draws it."""
    jp.locator(f'#replay-tracks button[data-track="{track["name"]}"]').click()
    frame = jp.locator("#replay")
    expect(frame).to_have_attribute("data-track", track["name"])
    expect(frame).to_have_attribute("src", re.compile(r"playbackPath=[^&]*" + re.escape(track["path"].replace("/", "%2F"))))
    for b in jp.locator("#replay-tracks button").all():
        expect(b).to_have_attribute("aria-pressed", str(b.get_attribute("data-track") == track["name"]).lower())
    canvas = jp.frame_locator("#replay").locator("canvas").first
    expect(canvas).to_be_visible(timeout=60_000)
    for _ in range(60):  # the new scene arrives over a few frames in software GL
        bb = canvas.bounding_box()
        if bb and bb["width"] > 50 and colour_share(jp.screenshot(clip=bb), track["color"]) > ROBOT_IN_VIEW:
            return
        jp.wait_for_timeout(500)
    raise AssertionError(f"the {track['label']} scene shows no robot in its colour")

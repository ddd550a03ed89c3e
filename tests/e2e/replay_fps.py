"""Frames per second of the 3D replay in headless Chromium with software WebGL (issue 25):
one scene per run (what the bundle holds now) against every run side by side with viser's
default lights and environment map (what it held before). Not a test (it measures, it judges nothing); run by hand:

    python tests/e2e/replay_fps.py OUT/<job-id>/ [...]      # unpacked bundles (`gaitmend run --out OUT`)

For each bundle it records the scenes from the bundle's trajectories and robot.xml, serves
them beside viser's own client, opens each in an iframe sized as the job page's replay
(1216 x 520 in a 1280 x 800 window; Debian's Chromium with the suite's flags) and counts
requestAnimationFrame callbacks in the iframe over three 5 s windows after 6 s of play.
Prints one JSON line per scene with the windows, their median and the load average."""

from __future__ import annotations

import functools
import http.server
import json
import os
import socketserver
import sys
import tempfile
import threading
from pathlib import Path

# the browser and flags of tests/e2e/conftest.py (Debian's Chromium, software WebGL)
CHROMIUM = os.environ.get("GAITMEND_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]
COUNT = """() => new Promise((done) => { let n = 0; const t0 = performance.now();
  const tick = () => { n++; if (performance.now() - t0 < 5000) requestAnimationFrame(tick);
                       else done(n / ((performance.now() - t0) / 1000)); };
  requestAnimationFrame(tick); })"""


def scenes(bundle: Path, out: Path) -> list[str]:
    """The bundle's runs as recorded now (one scene each) and side by side with viser's
    default lights (dynamic shadows) and environment map, as recorded before issue 25;
    returns the file names."""
    import mujoco
    import numpy as np
    import viser._scene_api as scene_api

    from app.jobs.registry import get_kind
    from app.results.replay import record, record_scenes, replay_tracks

    kind = get_kind(json.loads((bundle / "manifest.json").read_text())["spec"]["kind"])
    model = mujoco.MjModel.from_xml_path(str(bundle / "robot.xml"))
    traces = {p.stem: dict(np.load(p)) for p in sorted((bundle / "trajectories").glob("*.npz"))}
    traces = {k: v for k, v in traces.items() if "qpos" in v}
    tracks = replay_tracks(kind, list(traces))
    names = []
    for path, data in record_scenes(model, traces, tracks).items():
        names.append(f"{bundle.name}-one-{path.replace('/', '_')}")
        (out / names[-1]).write_bytes(data)
    # viser's defaults: shadows on, the default environment map, no hemisphere light
    saved = {k: getattr(scene_api.SceneApi, k) for k in ("configure_default_lights", "configure_environment_map",
                                                          "add_light_hemisphere")}
    for k in saved:
        setattr(scene_api.SceneApi, k, lambda self, *a, **kw: None)
    try:
        data = record(model, {t.name: traces[t.name] for t in tracks}, tracks=tracks)
    finally:
        for k, f in saved.items():
            setattr(scene_api.SceneApi, k, f)
    names.append(f"{bundle.name}-side-by-side-shadows.viser")
    (out / names[-1]).write_bytes(data)
    return names


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:  # one line per request would bury the figures
        pass


def measure(site: Path, names: list[str]) -> None:
    import viser
    from playwright.sync_api import sync_playwright

    (site / "viser").symlink_to(Path(viser.__file__).parent / "client" / "build")
    (site / "host.html").write_text('<!doctype html><body style="margin:32px">'
                                    '<iframe id="r" style="width:1216px;height:520px;border:0"></iframe>')
    handler = functools.partial(_Quiet, directory=str(site))
    srv = socketserver.ThreadingTCPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    base = f"http://127.0.0.1:{srv.server_address[1]}"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        for name in names:
            pg = browser.new_page(viewport={"width": 1280, "height": 800})
            pg.goto(f"{base}/host.html")
            pg.evaluate(f"document.getElementById('r').src = '/viser/?playbackPath=/{name}'")
            pg.frame_locator("#r").locator("canvas").first.wait_for(state="visible", timeout=60_000)
            frame = next(f for f in pg.frames if "/viser/" in f.url)
            frame.wait_for_function("() => document.querySelector('[role=slider]')", timeout=60_000)
            pg.wait_for_timeout(6000)
            fps = [round(frame.evaluate(COUNT), 1) for _ in range(3)]
            print(json.dumps({"scene": name, "fps_5s_windows": fps, "median": sorted(fps)[1],
                              "load1": Path("/proc/loadavg").read_text().split()[0]}), flush=True)
            pg.close()
        browser.close()
    srv.shutdown()


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp)
        measure(site, [n for b in sys.argv[1:] for n in scenes(Path(b).resolve(), site)])

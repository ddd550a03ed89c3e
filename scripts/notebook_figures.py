"""The figures docs/notebook.md publishes, measured and written to docs/notebook_figures.json
(issue 28: no number typed by hand); `gaitmend docs` renders them into the page
(app/results/notebook_figures.py).

    python scripts/notebook_figures.py [--parts overhead,video] [--out docs/notebook_figures.json]

- overhead: a served instance (`gaitmend serve`, embedded broker, SQLite, one worker, in a
  temporary folder) runs one small recovery job (10 s walks, DE 4 x 1, no controls or
  robustness re-runs); the job is read 40 times through the Python client and 40 times
  with bare httpx, interleaved, and the difference of the medians is the client's cost per
  call (what tests/client/test_client.py::test_overhead_per_call asserts on).
- video: `gaitmend video` renders that job's bundle (a 10 s walk) at the defaults, in a
  child process whose wall time and CPU time (user + sys, from getrusage) are recorded.

Each part replaces its earlier entry in the file; the machine (cores, load average before
and after, the date) is recorded with it, since both figures depend on it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import resource
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SPEC = {"kind": "recovery", "damage": {"lost_legs": [1, 6]}, "search": {"population": 4, "generations": 1},
        "controls": {"random_search": False}, "robustness": {"cases": [], "held_out": 0}}
READS = 40
GAITMEND = str(Path(sys.executable).with_name("gaitmend"))  # the venv's entry point


def _machine() -> dict:
    return {"date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d"), "cores": os.cpu_count(),
            "load_before": round(os.getloadavg()[0], 2), "python": platform.python_version()}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _serve(tmp: Path) -> tuple[subprocess.Popen, str]:
    import httpx

    port = _free_port()
    env = {**os.environ, "GAITMEND_DATA_DIR": str(tmp / "data"), "GAITMEND_TOKEN": ""}
    log = open(tmp / "serve.log", "w")
    proc = subprocess.Popen([GAITMEND, "serve", "--port", str(port)], env=env,
                            stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    for _ in range(300):
        try:
            if httpx.get(f"{base}/api/health", timeout=2).status_code == 200:
                return proc, base
        except httpx.HTTPError:
            pass
        if proc.poll() is not None:
            break
        time.sleep(0.5)
    proc.terminate()
    raise SystemExit(f"gaitmend serve did not come up:\n{(tmp / 'serve.log').read_text()[-3000:]}")


def overhead(base: str, job_id: str) -> dict:
    import httpx

    import gaitmend

    raw, ours = [], []
    with gaitmend.Client(base, token="") as client, httpx.Client(base_url=base) as h:
        client.job(job_id)  # warm both connections
        h.get(f"/api/jobs/{job_id}").json()
        for _ in range(READS):
            t = time.perf_counter()
            h.get(f"/api/jobs/{job_id}").json()
            raw.append(time.perf_counter() - t)
            t = time.perf_counter()
            client.job(job_id)
            ours.append(time.perf_counter() - t)
    return {"reads": READS, "client_median_ms": 1e3 * statistics.median(ours),
            "httpx_median_ms": 1e3 * statistics.median(raw),
            "overhead_ms": 1e3 * (statistics.median(ours) - statistics.median(raw))}


def video(bundle: Path, tmp: Path) -> dict:
    out = tmp / "walk.mp4"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    r = subprocess.run([GAITMEND, "video", str(bundle), "--out", str(out), "--json"],
                       capture_output=True, text=True, check=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    info = json.loads(r.stdout.strip().splitlines()[-1])
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"frames": info["frames"], "width": info["width"], "height": info["height"],
            "video_seconds": info["seconds"], "wall_s": wall, "cpu_s": cpu, "mp4_bytes": out.stat().st_size,
            "command": "gaitmend video BUNDLE --out walk.mp4 (defaults)"}


def measure(parts: list[str]) -> dict:
    import gaitmend

    found: dict = {}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        proc, base = _serve(tmp)
        try:
            with gaitmend.Client(base, token="") as client:
                job = client.submit(SPEC).wait(progress=False, timeout=1800)
                if job.status != "succeeded":
                    raise SystemExit(f"the measurement job {job.status}: {job.info.get('error')}")
                bundle = job.bundle(tmp / "job.zip")
            if "overhead" in parts:
                found["overhead"] = _machine() | {"spec": SPEC} | overhead(base, job.id)
            if "video" in parts:
                found["video"] = _machine() | {"spec": SPEC} | video(bundle, tmp)
        finally:
            proc.terminate()
            proc.wait(60)
    for v in found.values():
        v["load_after"] = round(os.getloadavg()[0], 2)
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parts", default="overhead,video")
    ap.add_argument("--out", type=Path, default=Path("docs/notebook_figures.json"))
    a = ap.parse_args()
    parts = [p for p in a.parts.split(",") if p]
    if set(parts) - {"overhead", "video"}:
        raise SystemExit("--parts: overhead, video")
    data = json.loads(a.out.read_text()) if a.out.exists() else {}
    data.update(measure(parts))
    data["command"] = "python scripts/notebook_figures.py"
    a.out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(json.dumps(data, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()

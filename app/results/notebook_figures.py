"""docs/notebook.md's measured figures, rendered from docs/notebook_figures.json (written by
``python scripts/notebook_figures.py``): the Python client's cost per call over bare httpx,
and the render time of a 10 s walk's video. They belong to no kind, so app/results/docs_gen.py
adds these sections to the kinds' own."""

from __future__ import annotations

from typing import Any

from app.jobs.reporting import Section, md_table, missing, num

JSON = "docs/notebook_figures.json"
COMMAND = "python scripts/notebook_figures.py"


def _machine(m: dict) -> str:
    return (f"measured on {m['date']} on a {m['cores']}-core machine, load average {m['load_before']:.1f} before "
            f"and {m['load_after']:.1f} after")


def render_overhead(data: list[Any]) -> str:
    d = (data[0] or {}).get("overhead")
    if not d:
        return missing(JSON, COMMAND)
    return (f"Difference of the medians: **{num(d['overhead_ms'])} ms** per call (the client "
            f"{num(d['client_median_ms'], '{:.1f}')} ms, bare httpx {num(d['httpx_median_ms'], '{:.1f}')} ms, "
            f"median of {d['reads']} reads each, interleaved; {_machine(d)}).\n")


def render_video(data: list[Any]) -> str:
    d = (data[0] or {}).get("video")
    if not d:
        return missing(JSON, COMMAND)
    share = 100 * d["cpu_s"] / d["wall_s"] if d["wall_s"] else float("nan")
    fps = round(d["frames"] / d["video_seconds"]) if d["video_seconds"] else "-"
    row = [f"{d['video_seconds']:.0f} s recovery walk, {d['width']}x{d['height']}, {fps} fps", d["frames"],
           f"{num(d['wall_s'], '{:.1f}')} (the process used {num(share, '{:.0f}')} % of a core)",
           num(d["cpu_s"], "{:.1f}"), num(d["cpu_s"] / d["frames"], "{:.3f}"), f"{d['mp4_bytes'] / 1e6:.1f} MB"]
    return (md_table(["video", "frames", "wall (s)", "CPU (s, user + sys)", "CPU per frame (s, the whole process / frames)", "MP4"], [row])
            + f"\n`{d['command']}`, {_machine(d)}.\n")


SECTIONS = (Section("notebook-overhead", (JSON,), render_overhead),
            Section("notebook-video", (JSON,), render_video))

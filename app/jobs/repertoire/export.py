"""The repertoire's own bundle files: the map as a table (archive.csv) and the controller
a robot runs any of its gaits with (the module the simulation ran, byte for byte)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

FILES = {
    "archive.csv": "the map, one row per elite (sorted by cell): cell, forward_m (the fitness), lateral_m, yaw_deg, "
                   "fell, energy_j, timestep_s, the descriptor (desc_<name>), each leg's contact share "
                   "(contact_<leg>) and the gait's parameters x0..x<n-1> in the controller's unit cube",
    "controller/repertoire_controller.py": "the periodic joint-space controller the simulation ran (numpy only, no "
                                           "gaitmend import): Layout.from_json(layout.json).setpoints_single(x, t)",
    "controller/layout.json": "the controller's data: the servos' joints in order, their ranges and stance (rad), "
                              "amplitude and offset fractions, the period range and fade-in",
    "controller/best.json": "the map's best gait: its parameters x, cell, descriptor and metrics",
}


def describe(path: str) -> str | None:
    """What one of the kind's own bundle members is (FILES, and the elites' replay traces)."""
    if path in FILES:
        return FILES[path]
    p = Path(path)
    if p.parent.name == "trajectories" and p.stem.startswith("elite_") and p.stem[6:].isdigit():
        fmt = "per-step arrays (NumPy .npz)" if p.suffix == ".npz" else "the same, flat (CSV)"
        return (f"the walk of the map's elite in cell {int(p.stem[6:])}, one trial as simulated, kept at 50 Hz "
                f"(an elite picked for the replay: the best half and a spread over the map): {fmt}")
    return None


def archive_csv(summary: dict) -> str:
    e, d = summary["elites"], summary["descriptor"]
    legs = summary["robot"]["legs"]
    n = len(e["cell"])
    dim = len(e["solution"][0]) if n else summary["controller"]["parameters"]
    buf = io.StringIO()
    w = csv.writer(buf)
    scal = ["lateral_m", "yaw_deg", "fell", "energy_j", "timestep_s"]
    w.writerow(["cell", "forward_m", *scal, *[f"desc_{x}" for x in d["names"]], *[f"contact_{l}" for l in legs],
                *[f"x{i}" for i in range(dim)]])
    for i in range(n):
        w.writerow([e["cell"][i], repr(float(e["objective"][i])), *[repr(float(e[k][i])) for k in scal],
                    *[repr(float(v)) for v in e["measures"][i]], *[repr(float(v)) for v in e["contact"][i]],
                    *[repr(float(v)) for v in e["solution"][i]]])
    return buf.getvalue()


def bundle_files(spec, result) -> dict[str, str]:
    s = result.summary
    layout = {k: s["controller"][k] for k in ("joints", "lo", "hi", "stance", "amplitude", "offset", "period_s",
                                              "ramp_s")}
    out = {"archive.csv": archive_csv(s),
           "controller/repertoire_controller.py": (Path(__file__).parent / "controller.py").read_text(),
           "controller/layout.json": json.dumps(layout, indent=2)}
    if s.get("best"):
        out["controller/best.json"] = json.dumps(s["best"], indent=2)
    return out

"""The damage atlas as a table, from a finished atlas study's bundle (or `study run` folder):
per leg loss, the recovered walk over seeds, how many seeds meet the target, whether the
nominal tripod already meets it, how many perturbed re-runs still meet it, and the
timestep convergence rule over every answer (each answer re-run at half its step is one
of its robustness cases).

    gaitmend study run recovery_atlas --out results/atlas
    python -m app.jobs.recovery.reproduce.atlas results/atlas          # or the served study's .zip
"""

from __future__ import annotations

import json
import statistics
import sys
import zipfile
from pathlib import Path

import numpy as np

from app.jobs.evidence import robustness_of
from app.jobs.recovery.reproduce.convergence import RULE_TEXT, check, halving_deltas
from app.jobs.recovery.metrics import TARGET


def load_points(src: Path) -> tuple[dict, list[dict]]:
    """(manifest, points) from a study bundle zip or a `study run --out` folder."""
    if src.is_file():
        with zipfile.ZipFile(src) as z:
            names = sorted(n for n in z.namelist() if n.startswith("points/") and n.endswith(".json"))
            return json.loads(z.read("manifest.json")), [json.loads(z.read(n)) for n in names]
    names = sorted((src / "points").glob("*.json"))
    return json.loads((src / "manifest.json").read_text()), [json.loads(p.read_text()) for p in names]


def _mmm(xs: list[float], scale: float = 1.0, digits: int = 1) -> str:
    xs = [scale * x for x in xs]
    return f"{statistics.median(xs):.{digits}f} [{min(xs):.{digits}f}, {max(xs):.{digits}f}]"


def table(points: list[dict]) -> str:
    groups: dict[tuple, list[dict]] = {}
    for p in points:
        if p.get("status") == "succeeded" and p.get("summary"):
            groups.setdefault(tuple(p["spec"]["damage"]["lost_legs"]), []).append(p)
    rows = ["| lost legs | seeds | forward (cm) | lateral (cm) | yaw (deg) | target met | baseline meets it | "
            "perturbed re-runs meeting it (of 7, per seed) |", "|---|---|---|---|---|---|---|---|"]
    at, half = {"x_f_m": [], "y_f_m": [], "yaw_f_deg": []}, {"x_f_m": [], "y_f_m": [], "yaw_f_deg": []}
    for k in sorted(groups, key=lambda k: (len(k), k)):
        ps = groups[k]
        ms = [p["summary"]["best"]["metrics"] for p in ps]
        met = sum(TARGET.met(m) for m in ms)
        base = any(TARGET.met(p["summary"]["baseline"]["metrics"]) for p in ps)
        robs = [robustness_of(p["summary"]) for p in ps]
        rob = [str(r.met) if r is not None else "-" for r in robs]
        rows.append(f"| {', '.join(map(str, k))} | {len(ps)} | {_mmm([m['y_f_m'] for m in ms], 100)} | "
                    f"{_mmm([m['x_f_m'] for m in ms], 100)} | {_mmm([m['yaw_f_deg'] for m in ms])} | {met}/{len(ps)} | "
                    f"{'**yes**' if base else 'no'} | {', '.join(rob)} |")
        for r, m in zip(robs, ms):
            h = next((c.metrics for c in (r.cases if r else []) if c.name == "dt_half"), None)
            if h is not None:
                for f in at:
                    at[f].append(m[f])
                    half[f].append(h[f])
    out = "\n".join(rows)
    if at["y_f_m"]:
        v = check(halving_deltas({f: np.array(x) for f, x in at.items()}, {f: np.array(x) for f, x in half.items()}))
        out += (f"\n\nConvergence rule ({RULE_TEXT}) over these {v['answers']} answers at half their step: "
                f"{'**passes**' if v['passes'] else '**fails**'}; forward moves at most "
                f"{100 * v['max_forward_rel']:.1f} %, {100 * v['share_within']:.0f} % of the answers stay within "
                f"the drift and yaw bands (median change {100 * v['median_lateral_m']:.1f} cm, "
                f"{v['median_yaw_deg']:.1f} deg; largest {100 * v['max_lateral_m']:.1f} cm, {v['max_yaw_deg']:.1f} deg).")
    return out


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    manifest, points = load_points(Path(sys.argv[1]))
    infeasible = manifest.get("infeasible") or []
    print(table(points))
    if infeasible:
        print("\nInfeasible, listed and never run: " + "; ".join(
            f"{x['overrides'].get('damage.lost_legs')} ({x['reason']})" for x in infeasible))


if __name__ == "__main__":
    main()

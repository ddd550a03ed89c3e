"""The map: a pyribs centroidal Voronoi (CVT) archive of gaits, its statistics, and its
exact JSON form for checkpoints.

- Centroids: pyribs' k-means over ``SAMPLES_PER_CELL`` uniform samples per cell of the
  descriptor's box, seeded by the job's seed, on one thread (the same centroids on any
  number of cores); a checkpoint carries them, so a resumed job never computes them again.
- Admission: a gait enters when its forward distance is above the cell's elite's (vanilla
  MAP-Elites: pyribs' threshold_min -inf, where a cell's threshold is its elite's objective)
  and it is admissible: at least ``min_forward_m`` forward and, unless fallen gaits are
  admitted, upright (``admissible``; the others are not offered to the archive). pyribs'
  finite threshold_min would switch to CMA-MAE's batch threshold rule (a mean of the
  batch's objectives per cell), whose thresholds an elite table does not hold.
- QD-score: the sum over elites of (forward distance - min_forward_m), summed exactly
  (math.fsum), so it does not depend on the order elites were added in.
- Exact restore: pyribs keeps its occupied cells in the order they were first filled, and
  draws parents by position in that order; ``dump`` writes the elites in that order and
  ``restore`` adds them back one by one in it, so a resumed archive draws the same parents.
"""

from __future__ import annotations

import math

import numpy as np
from ribs.archives import CVTArchive, k_means_centroids

SAMPLES_PER_CELL = 10  # k-means samples per centroid (pyribs' default is 100,000 in all)
MIN_SAMPLES = 1000

# The per-elite metrics an archive stores beside solution, objective (forward_m) and measures.
SCALARS = ("lateral_m", "yaw_deg", "fell", "energy_j", "timestep_s")


def centroids(cells: int, ranges: list[tuple[float, float]], seed: int) -> np.ndarray:
    from threadpoolctl import threadpool_limits

    samples = max(MIN_SAMPLES, SAMPLES_PER_CELL * cells)
    with threadpool_limits(limits=1):  # k-means' sums in one fixed order on any machine's core count
        points, _ = k_means_centroids(centroids=cells, ranges=ranges, samples=samples, seed=seed)
    return np.asarray(points, dtype=float)


def make(points: np.ndarray, dim: int, ranges: list[tuple[float, float]], n_legs: int, min_forward: float,
         seed: int) -> CVTArchive:
    extra = {k: ((), np.float64) for k in SCALARS} | {"contact": ((max(n_legs, 1),), np.float64)}
    return CVTArchive(solution_dim=dim, centroids=np.asarray(points), ranges=ranges, qd_score_offset=min_forward,
                      seed=seed, extra_fields=extra)


def fields(metrics: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The archive's extra fields of scored gaits."""
    out = {k: np.asarray(metrics[k], dtype=float) for k in SCALARS}
    out["contact"] = np.asarray(metrics["contact"], dtype=float)
    return out


def admissible(metrics: dict[str, np.ndarray], min_forward: float, admit_fallen: bool) -> np.ndarray:
    """(P,) True for the gaits offered to the archive (module doc)."""
    ok = np.asarray(metrics["forward_m"], dtype=float) >= min_forward
    return ok if admit_fallen else ok & ~np.asarray(metrics["fell"], dtype=bool)


def add(archive: CVTArchive, x: np.ndarray, metrics: dict[str, np.ndarray], measures: np.ndarray, min_forward: float,
        admit_fallen: bool) -> int:
    """Offers the admissible gaits to the archive; returns how many were admissible."""
    ok = admissible(metrics, min_forward, admit_fallen)
    if np.any(ok):
        extra = {k: v[ok] for k, v in fields(metrics).items()}
        archive.add(x[ok], np.asarray(metrics["forward_m"], dtype=float)[ok], measures[ok], **extra)
    return int(np.sum(ok))


def stats(archive: CVTArchive, min_forward: float) -> dict[str, float]:
    """coverage (share of cells filled), qd_score (module doc), best forward distance, elites."""
    obj = archive.data("objective")
    n = int(len(obj))
    return {"elites": n, "coverage": n / archive.cells,
            "qd_score": math.fsum(float(v) - min_forward for v in obj),
            "best": float(np.max(obj)) if n else None}


def dump(archive: CVTArchive) -> dict[str, list]:
    """Every elite, in first-filled order, exactly (floats as JSON round-trips them)."""
    data = archive.data()  # ArchiveDataFrame-free dict, rows in the occupied order
    return {k: np.asarray(v).tolist() for k, v in data.items() if k != "threshold"}


def restore(archive: CVTArchive, d: dict[str, list]) -> None:
    """Adds the dumped elites back, one by one in their order (module doc)."""
    n = len(d["index"])
    cols = {k: np.asarray(v, dtype=float) for k, v in d.items() if k != "index"}
    extra = [k for k in cols if k not in ("solution", "objective", "measures")]
    for i in range(n):
        archive.add(cols["solution"][i:i + 1], cols["objective"][i:i + 1], cols["measures"][i:i + 1],
                    **{k: cols[k][i:i + 1] for k in extra})
    if list(np.asarray(archive.data("index")).tolist()) != list(d["index"]):
        raise ValueError("checkpoint: the archive's elites did not come back to their cells")


def table(archive: CVTArchive) -> dict[str, list]:
    """The elites sorted by cell: {"cell", "objective", "measures", "solution", and each
    extra field} (JSON lists)."""
    data = archive.data()
    order = np.argsort(np.asarray(data["index"]), kind="stable")
    return {("cell" if k == "index" else k): np.asarray(v)[order].tolist() for k, v in data.items() if k != "threshold"}

"""A repertoire built as islands: a study whose points are independent MAP-Elites runs of one
base spec (each its own derived seed and a share of the iterations), on any number of
workers, merged into one archive reproducibly.

- ``island_seed(seed, i)``: island i's seed, drawn from ``SeedSequence((seed, ISLANDS, i))``
  (the base seed alone decides every island's).
- ``shares(iterations, n)``: the base spec's iterations split over n islands as evenly as
  possible (the first ``iterations % n`` islands one more), so the islands together score
  the base spec's budget.
- ``islands_study(base, n)``: the study spec (app/studies/spec.py) of those n islands; its
  base pins ``archive.centroid_seed`` to the base spec's centroids, so every island fills
  the same cells (islands with centroids of their own seeds lost elites in the merge: two
  elites in two cells of one tessellation often share a cell of another; on one measured
  island 36 elites became 26).
- ``merge(base, islands)``: a fresh archive of the base spec's centroids (as a single run of
  the base spec would have), every island's elites inserted in a fixed order (island by
  island in index order, each island's elites in cell order, one island a batch); an elite
  lands in the merged archive's cell of its descriptor and keeps it only if it walks
  further than any earlier island's elite there, so each cell holds the best of the
  islands' elites in it. The merged archive is
  therefore the same whatever order the islands finished in, and on whatever workers.
  Islands' random controls are not merged (a summary holds their figures, not their gaits).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from app.jobs.repertoire import archive as arc

ISLANDS = 0x15_1A_4D  # the seed sequence's word for "island": apart from the iteration words of run.py
SEED_MAX = 2**31 - 1  # the spec's bound on a seed


def island_seed(seed: int, i: int) -> int:
    return int(np.random.SeedSequence([int(seed), ISLANDS, int(i)]).generate_state(1)[0]) & SEED_MAX


def shares(iterations: int, n: int) -> list[int]:
    if not 1 <= n <= iterations:
        raise ValueError(f"islands: {n} islands need 1..{iterations} (the base spec's search.iterations)")
    q, r = divmod(int(iterations), int(n))
    return [q + (1 if i < r else 0) for i in range(n)]


def islands_study(base: Mapping[str, Any], n: int, name: str | None = None) -> dict[str, Any]:
    """The study of ``n`` islands of ``base`` (a repertoire spec as JSON; its ``seed`` and
    ``search.iterations`` are the whole map's): point i sets ``seed`` to island_seed(seed, i)
    and ``search.iterations`` to its share."""
    from app.jobs.repertoire.spec import RepertoireSpec

    from app.jobs.repertoire.run import centroid_seed

    spec = RepertoireSpec.parse(dict(base))
    points = [{"seed": island_seed(spec.seed, i), "search.iterations": k}
              for i, k in enumerate(shares(spec.search.iterations, n))]
    shared = spec.model_dump(mode="json")
    shared["archive"]["centroid_seed"] = centroid_seed(spec)  # every island fills the base's cells
    return {"name": name or f"repertoire: {n} islands of seed {spec.seed}, {spec.search.iterations} iterations",
            "base": shared, "points": points,
            "report": {"group_by": [], "metrics": ["archive.coverage", "archive.qd_score", "archive.best_forward_m"]}}


def _check_same(summaries: list[dict]) -> None:
    keys = ("descriptor", "controller")
    first = summaries[0]
    for i, s in enumerate(summaries[1:], 1):
        for k in keys:
            if s[k] != first[k]:
                raise ValueError(f"islands: island {i}'s {k} differs from island 0's (not islands of one base spec)")
        if s["archive"]["cells"] != first["archive"]["cells"] or s["archive"]["qd_offset_m"] != first["archive"]["qd_offset_m"]:
            raise ValueError(f"islands: island {i}'s archive differs from island 0's (cells or QD-score offset)")


def merge(base: Mapping[str, Any], islands: Mapping[int, dict] | list[tuple[int, dict]]):
    """The merged archive (pyribs CVTArchive) of the islands' summaries, {index: summary} or
    (index, summary) pairs in any order (module doc)."""
    from app.jobs.repertoire.run import centroid_seed
    from app.jobs.repertoire.spec import RepertoireSpec

    spec = RepertoireSpec.parse(dict(base))
    pairs = sorted(islands.items() if isinstance(islands, Mapping) else list(islands), key=lambda p: p[0])
    if not pairs:
        raise ValueError("islands: nothing to merge")
    if len({i for i, _ in pairs}) != len(pairs):
        raise ValueError("islands: an island index is listed twice")
    summaries = [s for _, s in pairs]
    _check_same(summaries)
    s0 = summaries[0]
    ranges = [tuple(b) for b in s0["descriptor"]["bounds"]]
    floor = float(s0["archive"]["qd_offset_m"])
    points = arc.centroids(spec.archive.cells, ranges, centroid_seed(spec))
    merged = arc.make(points, int(s0["controller"]["parameters"]), ranges, len(s0["robot"]["legs"]), floor, spec.seed)
    for s in summaries:
        e = s["elites"]
        if not e["cell"]:
            continue
        order = np.argsort(np.asarray(e["cell"]), kind="stable")
        extra = {k: np.asarray(e[k], dtype=float)[order] for k in (*arc.SCALARS, "contact")}
        merged.add(np.asarray(e["solution"], dtype=float)[order], np.asarray(e["objective"], dtype=float)[order],
                   np.asarray(e["measures"], dtype=float)[order], **extra)
    return merged


def merged_summary(base: Mapping[str, Any], islands: Mapping[int, dict] | list[tuple[int, dict]]) -> dict[str, Any]:
    """The merged map's figures ({"archive": coverage, qd_score, elites, best_forward_m,
    cells}, per island the same, and the merged elites as archive.table gives them)."""
    pairs = sorted(islands.items() if isinstance(islands, Mapping) else list(islands), key=lambda p: p[0])
    merged = merge(base, pairs)
    floor = float(pairs[0][1]["archive"]["qd_offset_m"])
    a = arc.stats(merged, floor)
    return {"archive": {"cells": merged.cells, "elites": a["elites"], "coverage": a["coverage"],
                        "qd_score": a["qd_score"], "best_forward_m": a["best"], "qd_offset_m": floor},
            "islands": [{"index": i, "elites": s["archive"]["elites"],
                         "coverage": s["archive"]["coverage"], "qd_score": s["archive"]["qd_score"],
                         "best_forward_m": s["archive"]["best_forward_m"],
                         "evaluations": s["search"]["evaluations"]} for i, s in pairs],
            "evaluations": sum(s["search"]["evaluations"] for _, s in pairs),
            "elites": arc.table(merged)}


def same_archive(a, b) -> bool:
    """Two archives hold the same elites, in the same cells and the same occupied order,
    bit for bit."""
    da, db = a.data(), b.data()
    if set(da) != set(db):
        return False
    return all(np.array_equal(np.asarray(da[k]), np.asarray(db[k])) for k in da)


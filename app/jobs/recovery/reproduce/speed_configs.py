"""The configurations issue 22's speed measurements compare (the paper's DE, the equal-quality
configuration and the alternatives tried), how a stored run is labelled by the configuration
it ran and found again, and the documented Table II runs (docs/table2.json) and the paper
DE's values they are compared with."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from app.jobs.recovery.spec import RecoverySpec


SCENARIOS = [(1, 6), (3, 4), (1,), (4,)]  # paper 000's Table II
ONLY_SEARCH = {"controls": {"random_search": False}, "robustness": {"cases": ["dt_half"], "held_out": 0}}
PAPER = {"search": {"population": 30, "generations": 60}}
# The equal-quality configuration: CMA-ES (the `cma` package behind the same ask/tell
# interface), 12 per generation, 1 ms; its first 48 generations walk 5 s, their displacements
# carried to 10 s (search.short_walks), then 36 generations of full 10 s walks: the steps of
# CMA-ES 12 x 60 on full walks (docs/recovery_speed.md has its runs and their wall times).
EQUAL = {"search": {"optimizer": "cmaes", "population": 12, "generations": 83,
                    "short_walks": {"walk_s": 5.0, "generations": 48}}}
# Other configurations (part name "alt_<name>"): the equal-quality configurations of before,
# CMA-ES 12 x 60 (before the faster step) and 12 x 82 (full walks); at about 12 x 60's budget,
# tried where it fell short (legs 3 & 4), a wider and a narrower CMA-ES generation and the
# paper's DE itself with a population of 12 and cut walks; and the short walks scored on their
# own F (without carrying them to 10 s). A run is labelled by the configuration it ran (its
# spec), so the runs of a configuration keep their label when EQUAL changes (``by_config``).
ALTERNATIVES = {
    "cmaes_12x60": {"search": {"optimizer": "cmaes", "population": 12, "generations": 60}},
    "cmaes_12x82": {"search": {"optimizer": "cmaes", "population": 12, "generations": 82}},
    "cmaes_20x36": {"search": {"optimizer": "cmaes", "population": 20, "generations": 36}},
    "cmaes_8x90": {"search": {"optimizer": "cmaes", "population": 8, "generations": 90}},
    "de_12x60_cut": {"search": {"population": 12, "generations": 60, "cut_walks": True}},
    "cmaes_12x83_short5_raw": {"search": {"optimizer": "cmaes", "population": 12, "generations": 83,
                                          "short_walks": {"walk_s": 5.0, "generations": 48, "extrapolate": False}}},
}


def _uniform(job, n: int, seed: int = 0) -> np.ndarray:
    """``n`` candidates drawn uniformly in ``job``'s bounds from ``seed`` (the measurements' batches)."""
    return job.lower + np.random.default_rng(seed).random((n, job.lower.size)) * (job.upper - job.lower)


# -- searches ------------------------------------------------------------------------------------

def _table2_rows(docs: Path) -> list[dict]:
    path = docs / "table2.json"
    return json.loads(path.read_text()) if path.exists() else []


def _documented(lost, seed: int, table2: list[dict]) -> dict | None:
    """Table II's (docs/table2.json's rows) paper-budget answer for this damage and seed at the default step."""
    dt = RecoverySpec().sim.timestep_s
    for r in table2:
        if (tuple(r["lost_legs"]) == tuple(lost) and r["seed"] == seed and r.get("timestep_s") == dt
                and r.get("generations") == 60 and r.get("population") == 30 and "best_params" in r):
            return r
    return None


def _labels() -> list[tuple[str, dict]]:
    """Each searched configuration's part name: "equal" for EQUAL, "alt_<name>" for ALTERNATIVES."""
    return [("equal", EQUAL)] + [(f"alt_{n}", c) for n, c in ALTERNATIVES.items()]


def _config(row: dict) -> dict:
    return {k: v for k, v in row["spec"]["search"].items() if k != "seed"}


def by_config(rows: list[dict]) -> list[dict]:
    """The rows with each equal-quality or alternative run labelled by the configuration its
    spec holds: "equal" for EQUAL's, "alt_<name>" for ALTERNATIVES' (what the label was when
    it ran does not matter)."""
    out = []
    for r in rows:
        if r["part"] == "equal" or r["part"].startswith("alt_"):
            part = next((name for name, cfg in _labels() if _config(r) == cfg["search"]), r["part"])
            r = r | {"part": part}
        out.append(r)
    return out


def _paper_by_seed(rows: list[dict], lost, table2: list[dict], own: Callable[[dict], Any],
                   documented: Callable[[dict], Any]) -> dict[int, Any]:
    """A value of the paper DE's answer per seed: ``own`` of this page's runs, else
    ``documented`` of docs/table2.json's (full walks; None: not there); rows that are not
    searches (no damage) are passed over."""
    rows = [r for r in rows if tuple(r.get("lost_legs", ())) == tuple(lost)]
    out = {r["seed"]: own(r) for r in rows if r["part"] == "paper"}
    for seed in {r["seed"] for r in rows} - set(out):
        doc = _documented(lost, seed, table2)
        value = None if doc is None else documented(doc)
        if value is not None:
            out[seed] = value
    return out


def _paper_fitness(rows: list[dict], lost, table2: list[dict]) -> dict[int, float]:
    """The paper DE's final F per seed."""
    return _paper_by_seed(rows, lost, table2, lambda r: r["fitness"], lambda d: d["best_fitness"])


def _paper_half_step(rows: list[dict], lost, table2: list[dict]) -> dict[int, bool]:
    """Whether the paper DE's answer meets the target at half the step, per seed (Table II's
    rows: their robustness case dt_half)."""
    def documented(d: dict) -> bool | None:
        case = (d.get("robustness") or {}).get("cases", {}).get("dt_half")
        return None if case is None else bool(case["target_met"])

    return _paper_by_seed(rows, lost, table2, lambda r: bool(r["half_step_met"]), documented)


# search.short_walks as tried: F of the short walk carried to the full walk's length, then
# the same without that (the short walk's own F); its controls on the same seeds: CMA-ES 12 with
# full walks for as many steps, and for 82 generations (more steps)
# (part labels as by_config gives them)
SHORT_ROWS = {"short walks": "equal", "short walks, own F": "alt_cmaes_12x83_short5_raw"}
SAME_STEPS, MORE_STEPS = "alt_cmaes_12x60", "alt_cmaes_12x82"


def _runs_of(rows: list[dict], part: str, lost) -> dict[int, dict]:
    """The runs labelled ``part`` (by_config: by the configuration they ran) on ``lost``, by seed."""
    return {r["seed"]: r for r in rows if r["part"] == part and tuple(r["lost_legs"]) == tuple(lost)}


# The answers a job's robustness block would judge, for the short walks against their controls:
# each set's answers (the seeds all three have) under every named case and on the held-out
# random models of their seed, so that "equal quality" covers the perturbed robot too.
PERTURBED_SETS = {"short walks": "equal", "CMA-ES 12 x 60, full walks (same steps)": SAME_STEPS, "paper DE": "paper"}

"""What a recovery reproduction keeps of a run (a row of docs/table2.json or of
docs/recovery_atlas.json), and the hexapod's leg losses those reproductions walk over. Shared
by Table II (experiments.py) and the damage atlas (atlas_check.py); presentation only, in no
ledger's science list."""

from __future__ import annotations

import itertools

from app.jobs.evidence import robustness_of

KEEP = ("x_f_m", "y_f_m", "yaw_f_deg", "tilt_max_deg", "fell")  # what a row keeps of each robustness case


def leg_losses() -> tuple[list[tuple[int, ...]], dict[str, list[tuple[int, ...]]]]:
    """Every 1- and 2-leg loss of the hexapod: (the feasible ones, {why not: the infeasible ones})."""
    from app.jobs.recovery.sequences import InfeasibleMorphology, check_feasible

    feasible, infeasible = [], {}
    for lost in [(leg,) for leg in range(1, 7)] + list(itertools.combinations(range(1, 7), 2)):
        try:
            check_feasible([leg for leg in range(1, 7) if leg not in lost])
        except InfeasibleMorphology as e:
            infeasible.setdefault(str(e), []).append(lost)
            continue
        feasible.append(lost)
    return feasible, infeasible


def feasible_losses() -> list[tuple[int, ...]]:
    return leg_losses()[0]


def best_curve(s: dict) -> list[list]:
    """A search's best F after each generation: [[generation, best F, evaluations so far], ...]
    (paper 000's Figs. 3, 6, 9 and 12 plot it; Table II rows written before it was kept have none)."""
    return [[h["generation"], h["best"], h["evaluations"]] for h in s["history"]]


def robustness_row(s: dict, keep: tuple[str, ...] = KEEP) -> dict:
    """The robustness block of a run as a row keeps it: per case the ``keep`` metrics and
    whether the target was met."""
    rob = robustness_of(s)
    cases = rob.cases if rob is not None else []
    return {"met": rob.met if rob else 0, "total": rob.total if rob else 0,
            "cases": {c.name: {k: c.metrics[k] for k in keep} | {"target_met": c.target_met} for c in cases}}


def search_row(lost, seed: int, generations: int, population: int, s: dict) -> dict:
    """A search's row: its damage, seed and budget, the baseline, the answer with its
    parameters, its robustness block and its best-F curve."""
    return {"lost_legs": list(lost), "seed": seed, "generations": generations, "population": population,
            "timestep_s": s["timestep_s"], "baseline": s["baseline"]["metrics"],
            "baseline_target_met": s["baseline"]["target_met"], "best": s["best"]["metrics"],
            "best_fitness": s["best"]["fitness"], "best_params": s["best"]["params"],
            "target_met": s["best"]["target_met"], "robustness": robustness_row(s), "gait": s["gait"]["name"],
            "curve": best_curve(s)}

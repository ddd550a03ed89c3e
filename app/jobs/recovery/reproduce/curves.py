"""How many generations the paper DE needs (paper 000, Figs. 3, 6, 9 and 12: "convergence in
all cases after almost 30 generations"), counted from the best-F-per-generation curves that
Table II's rows (docs/table2.json) and the atlas's runs (docs/recovery_atlas.json) keep
(``curve``: [[generation, best F, evaluations], ...]; rows written before the curve was kept
have none and are not counted)."""

from __future__ import annotations

import statistics

from app.jobs.reporting import md_table, missing

PAPER_GENERATIONS = 30  # "after almost 30 generations" (paper 000, Sec. V)
SHARES = (0.95, 0.99)


def reached(curve: list[list], share: float) -> int:
    """The first generation whose best F is at least ``share`` of the final best F."""
    final = curve[-1][1]
    return next(g for g, best, _ in curve if best >= share * final)


def _best_at(curve: list[list], generation: int) -> float:
    """The best F after ``generation`` (the last one if the search ran fewer)."""
    return next(b for g, b, _ in curve if g == min(generation, curve[-1][0]))


def _mmm(xs: list[float], fmt: str = "{:.0f}") -> str:
    return f"{fmt.format(statistics.median(xs))} [{fmt.format(min(xs))}, {fmt.format(max(xs))}]"


def _damage(lost) -> str:
    return ("legs " if len(lost) > 1 else "leg ") + " & ".join(map(str, lost))


def generation_rows(rows: list[dict]) -> list[list]:
    """Per damage (one leg lost first, then two): runs with a curve, the generations to 95 % and 99 % of the
    final F, the share of the final F at the paper's generation 30, runs still improving after it."""
    groups: dict[tuple, list[list]] = {}
    for r in rows:
        if r.get("curve") and r["curve"][-1][1] > 0:
            groups.setdefault(tuple(r["lost_legs"]), []).append(r["curve"])
    out = []
    for lost, curves in sorted(groups.items(), key=lambda kv: (len(kv[0]), kv[0])):
        at30 = [_best_at(c, PAPER_GENERATIONS) / c[-1][1] for c in curves]
        later = sum(share < 1.0 for share in at30)  # the final F is above generation 30's
        out.append([_damage(lost), len(curves), *(_mmm([reached(c, s) for c in curves]) for s in SHARES),
                    _mmm([100 * a for a in at30]), f"{later}/{len(curves)}"])
    return out


def render_generations(rows: list[dict], source: str, command: str) -> str:
    """The generations table of ``rows`` (Table II's or the atlas's), or what writes them."""
    body = generation_rows(rows)
    if not body:
        return missing(source, command) if not rows else (
            f"*None of the {len(rows)} runs in {source} keeps its best F per generation (they were written before "
            f"the curve was kept); runs appended by `{command}` from now on do.*\n")
    gens = sorted({r["generations"] for r in rows if r.get("curve")})
    return (f"Best F per generation, from the runs in {source} that keep it (DE {', '.join(map(str, gens))} "
            "generations after the first). Paper 000 (Figs. 3, 6, 9, 12) reports convergence 'in all cases after "
            f"almost {PAPER_GENERATIONS} generations'. Generation 0 is the initial population.\n\n"
            + md_table(["damage", "runs", "generation reaching 95 % of the final F, median [min, max]", "99 %",
                        f"F at generation {PAPER_GENERATIONS}, % of the final F", f"still improving after generation "
                        f"{PAPER_GENERATIONS}"], body))

"""Issue 28's peers of the paper DE on Table II: scipy's differential_evolution and CMA-ES
at the paper DE's budget (population x (generations + 1) walks of the default walk at the
default step: 30 x 61 = 1830 walks of 10 s at 1 ms) on the four Table II damages, seeds
0 .. seeds - 1 (app/jobs/recovery/reproduce/peers.py runs them). `gaitmend reproduce recovery-peers
--write-docs`; every finished run (one method, damage and seed) is appended to
docs/table2_peers.json when it ends, and a re-run skips those already there at this code
version.

The Table II page (experiments.table_markdown) pairs them seed by seed with our DE's runs
in docs/table2.json (``comparisons_markdown``): our DE against its random-search control,
against scipy's DE and against CMA-ES, each damage and pooled, with the paired statistics
of app/jobs/stats.py and the success rates with a Wilson interval.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from app.jobs.ledger import Ledger, current_runs, machine_time
from app.jobs.recovery.reproduce import science_files
from app.jobs.reporting import md_table

JSON = "docs/table2_peers.json"
COMMAND = "gaitmend reproduce recovery-peers --write-docs"
SCIENCE = science_files.BASE + ("app/jobs/recovery/reproduce/peers.py", "app/optim/scipy_de.py",
                         "app/optim/cmaes.py")
SCENARIOS = ((1, 6), (3, 4), (1,), (4,))  # Table II's four damages (experiments.SCENARIOS)
NAMES = {"ours": "our DE", "random_search": "random search", "scipy_de": "scipy DE", "cmaes": "CMA-ES"}


class PeersParams(BaseModel):
    seeds: int = Field(5, ge=1, le=100, description="seeds per damage (0 .. seeds-1; the issue asks >= 5)")
    population: int = Field(30, ge=5, le=1000, description="population of both peers (paper DE: 30)")
    generations: int = Field(60, ge=1, le=10000, description="generations after the initial population (paper: 60)")
    methods: str = Field("scipy_de,cmaes", pattern=r"^(scipy_de|cmaes)(,(scipy_de|cmaes))*$",
                         description="which peers: scipy's differential_evolution, CMA-ES (app/optim/cmaes.py)")
    json_out: Path | None = Field(Path(JSON), description="the ledger: each run is appended when it ends")


def run_peers(p: PeersParams, log: Callable[[str], None] = print) -> str:
    """Seed by seed (a cut-short reproduction still has every damage), each damage, each
    method: a run already in the ledger at this code version is skipped."""
    from app.jobs.recovery.reproduce.peers import peer_spec, run_peer

    methods = p.methods.split(",")
    led = Ledger(p.json_out, "recovery-peers", COMMAND, p.model_dump(mode="json"), SCIENCE,
                 planned=len(SCENARIOS) * p.seeds * len(methods))
    for seed in range(p.seeds):
        for lost in SCENARIOS:
            for method in methods:
                name = f"legs {'-'.join(map(str, lost))} seed {seed} {method}"
                spec = peer_spec(method, lost, seed, p.population, p.generations) | {"method": method}
                if led.find(spec, seed) is None:
                    log(f"{name}: searching ({p.population} x {p.generations + 1} walks)")
                led.run(name, spec, seed, lambda: run_peer(method, lost, seed, p.population, p.generations), log)
    runs = [r["result"] for r in current_runs(led.data)]
    return (f"{len(runs)} of {led.data['planned']} planned peer runs in {p.json_out} (code {led.version}); "
            f"machine time {machine_time(led.data)['wall_s']:.0f} s wall. The Table II page pairs them with our DE: "
            "`gaitmend reproduce recovery --render-only --write-docs`.\n")


# -- the Table II page's comparisons -----------------------------------------------------------

def peer_results(data: dict | None, population: int, generations: int, timestep: float) -> list[dict]:
    """The peers' results at this budget and step (the file's current code version)."""
    if not data:
        return []
    return [r["result"] for r in current_runs(data) if r["result"]["population"] == population
            and r["result"]["generations"] == generations and r["result"]["timestep_s"] == timestep]


def by_method(rows: list[dict], peers: list[dict]) -> dict[str, dict[tuple, dict]]:
    """{method: {(damage, seed): {"fitness", "forward_cm", "target_met", "fell"}}}: our DE and
    its random-search control from Table II's rows, the peers from their ledger."""
    out: dict[str, dict[tuple, dict]] = {m: {} for m in NAMES}
    for r in rows:
        key = (tuple(r["lost_legs"]), r["seed"])
        out["ours"][key] = {"fitness": r["best_fitness"], "forward_cm": 100 * r["best"]["y_f_m"],
                            "target_met": bool(r["target_met"]), "fell": bool(r["best"]["fell"])}
        rs = r.get("random_search")
        if rs is not None:
            out["random_search"][key] = {"fitness": rs["fitness"], "forward_cm": 100 * rs["metrics"]["y_f_m"],
                                         "target_met": bool(rs["target_met"]), "fell": bool(rs["metrics"]["fell"])}
    for r in peers:
        out[r["method"]][(tuple(r["lost_legs"]), r["seed"])] = {
            "fitness": r["fitness"], "forward_cm": r["y_cm"], "target_met": bool(r["target_met"]),
            "fell": bool(r["metrics"]["fell"])}
    return out


def compare(ours: dict[tuple, dict], other: dict[tuple, dict], key: str, names: tuple[str, str]) -> dict:
    """Ours against ``other`` on ``key`` over the (damage, seed) pairs both have: app/jobs/stats.py's
    paired statistics (positive = ours higher) and the share of pairs ours wins."""
    from app.jobs.stats import paired

    pairs = sorted(set(ours) & set(other))
    r = paired([ours[k][key] for k in pairs], [other[k][key] for k in pairs], names=names)
    return r | {"wins": sum(d > 0 for d in r["differences"]), "pairs": pairs}


def _ci(r: dict, digits: int = 2) -> str:
    if r["n"] == 0:
        return "-"
    ci = "no interval (n < 2)" if r["ci"] is None else f"[{r['ci'][0]:+.{digits}f}, {r['ci'][1]:+.{digits}f}]"
    dz = "" if r["effect_size"] is None else f", d_z {r['effect_size']:.2f}"
    return f"{r['mean_diff']:+.{digits}f} {ci}{dz}"


def _p(r: dict) -> str:
    return "-" if r["p"] is None or r["n"] == 0 else f"{r['p']:.3g}"


def comparison_rows(methods: dict[str, dict[tuple, dict]]) -> list[list]:
    """One row per comparison (our DE vs each control) and damage, then pooled over damages."""
    out = []
    for other in ("random_search", "scipy_de", "cmaes"):
        if not set(methods["ours"]) & set(methods[other]):
            out.append([f"our DE vs {NAMES[other]}", "-", 0, "no pairs yet", "-", "-", "-", "-", "-", "-", "-"])
            continue
        for lost in [*SCENARIOS, None]:
            keep = (lambda k: True) if lost is None else (lambda k, lost=lost: k[0] == lost)
            ours = {k: v for k, v in methods["ours"].items() if keep(k)}
            theirs = {k: v for k, v in methods[other].items() if keep(k)}
            names = (NAMES["ours"], NAMES[other])
            f, y = compare(ours, theirs, "fitness", names), compare(ours, theirs, "forward_cm", names)
            where = "all damages" if lost is None else _damage(lost)
            if f["n"] == 0:
                out.append([f"our DE vs {NAMES[other]}", where, 0, "no pairs yet", "-", "-", "-", "-", "-", "-", "-"])
                continue
            out.append([f"our DE vs {NAMES[other]}", where, f["n"], _ci(f), f"{f['median_diff']:+.2f}",
                        f"{f['wins']}/{f['n']}", _p(f), f["verdict"], _ci(y, 1), _p(y), y["verdict"]])
    return out


def _damage(lost: tuple[int, ...]) -> str:
    return ("legs " if len(lost) > 1 else "leg ") + " & ".join(map(str, lost))


def rate(k: int, n: int) -> str:
    """k/n with its 95 % Wilson interval, in per cent."""
    from app.jobs.recovery.reproduce.loop_check import wilson

    if n == 0:
        return "-"
    lo, hi = wilson(k, n)
    return f"{k}/{n} [{100 * lo:.0f}, {100 * hi:.0f} %]"


def method_rows(methods: dict[str, dict[tuple, dict]]) -> list[list]:
    """Per damage and method: seeds, F median [min, max], forward median, falls, target met."""
    out = []
    for lost in SCENARIOS:
        for m, runs in methods.items():
            rs = [v for k, v in sorted(runs.items()) if k[0] == lost]
            if not rs:
                continue
            f = [v["fitness"] for v in rs]
            out.append([_damage(lost), NAMES[m], len(rs), f"{statistics.median(f):.2f} [{min(f):.2f}, {max(f):.2f}]",
                        f"{statistics.median(v['forward_cm'] for v in rs):.1f}", sum(v["fell"] for v in rs),
                        rate(sum(v["target_met"] for v in rs), len(rs))])
    for m, runs in methods.items():
        if runs:
            out.append(["all damages", NAMES[m], len(runs), "-", "-", sum(v["fell"] for v in runs.values()),
                        rate(sum(v["target_met"] for v in runs.values()), len(runs))])
    return out


def comparisons_markdown(rows: list[dict], peers_data: dict | None, population: int, generations: int,
                         timestep: float) -> str:
    """The Table II page's block: every method at equal budget, success rates, and our DE
    against each control, paired by damage and seed."""
    from app.jobs.stats import PAIRED_NOTE

    peers = peer_results(peers_data, population, generations, timestep)
    methods = by_method(rows, peers)
    walks = population * (generations + 1)
    out = [f"Every method at the same budget: {population} x {generations + 1} = {walks} walks of the same 10 s walk "
           f"at {1000 * timestep:g} ms on the same evaluator, bounds and objective (Eq. 5). Our DE and its "
           "random-search control (uniform in the bounds, its own stream of the run's seed): docs/table2.json; "
           "scipy's `differential_evolution` (current-to-best/1/bin, our F and CR, our population exactly, deferred "
           "updating, no polish) and CMA-ES (app/optim/cmaes.py through our search loop): "
           + (f"{JSON} ({len(peers)} run{'s' if len(peers) > 1 else ''}, code {peers_data['code_version']}, "
              f"{machine_time(peers_data)['wall_s']:.0f} s wall)." if peers else
              f"*no data yet: `{COMMAND}` writes {JSON}.*"), "",
           md_table(["damage", "method", "seeds", "F median [min, max]", "forward y median (cm)", "fell",
                     "target met [95 % Wilson]"], method_rows(methods)),
           "Paired by damage and seed (difference = our DE - the other; positive favours our DE). " + PAIRED_NOTE
           + " 'ours wins': pairs where our DE's F is higher. Pooled rows pair across damages whose F scales differ "
             "(leg 1's F is several times legs 1 & 6's), so their mean is dominated by the large-F damages; the "
             "wins share and the per-damage rows do not have that weight.", "",
           md_table(["comparison", "damage", "pairs (n)", "F: mean difference [95 % CI], d_z", "median difference",
                     "ours wins", "Wilcoxon p", "F: verdict", "forward (cm): mean difference [95 % CI]",
                     "Wilcoxon p", "forward: verdict"], comparison_rows(methods))]
    return "\n".join(out)


def summary_line(rows: list[dict], peers_data: dict | None, population: int, generations: int,
                 timestep: float) -> str:
    """README's line for paper 000: Table II's target rate beside its random-search control's,
    and our DE's F against each control pooled over damages and seeds, with the verdicts of
    the page's paired table (docs/table2.md)."""
    if not rows:
        return ""
    methods = by_method(rows, peer_results(peers_data, population, generations, timestep))
    ours = methods["ours"]
    seeds = sorted({k[1] for k in ours})
    met = lambda m: f"{sum(v['target_met'] for v in methods[m].values())}/{len(methods[m])}"  # noqa: E731
    verdicts = []
    for other in ("random_search", "scipy_de", "cmaes"):
        if set(ours) & set(methods[other]):
            r = compare(ours, methods[other], "fitness", (NAMES["ours"], NAMES[other]))
            verdicts.append(f"against {NAMES[other]} ({r['n']} pairs) {r['verdict']}")
    damages = len({k[0] for k in ours})
    return (f"- **recovery** (paper 000, Table II's {damages} damage{'s' if damages > 1 else ''} x seeds {seeds[0]}-{seeds[-1]}, "
            f"DE {population} x {generations} at {1000 * timestep:g} ms): target met in {met('ours')} runs "
            f"(random search at the same budget: {met('random_search')}); {_evidence(rows)}; our DE's F, paired by "
            "damage and seed, " + "; ".join(verdicts) + " ([docs/table2.md](docs/table2.md)).\n")


def _evidence(rows: list[dict]) -> str:
    """What the target rate stands on: the damages where the nominal tripod already meets it
    without any search, and the answers re-run at half the step and under the other cases."""
    base = sorted({_damage(tuple(r["lost_legs"])) for r in rows if r["baseline_target_met"]})
    half = [r["robustness"]["cases"]["dt_half"]["target_met"] for r in rows if "dt_half" in r["robustness"]["cases"]]
    cases = statistics.median(r["robustness"]["met"] for r in rows)
    return (f"the nominal tripod, no search, already meets it with {', '.join(base) if base else 'none'} lost; "
            f"the answers keep it at half the step in {sum(half)}/{len(half)} and in a median {cases:g} of the "
            f"{rows[0]['robustness']['total']} robustness cases")

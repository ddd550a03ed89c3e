"""Whether a result reproduces on another machine (issue 45), rendered from
docs/reproducibility.json: each reference result (the README's example jobs, made once and
committed under docs/reproducibility/) re-run by `gaitmend reproduce machines` on a machine
and compared number by number as `gaitmend verify` does (app/results/verify.py: identical,
equal within the stated tolerance, or different). The second table reads the figures of
docs/benchmarks.json that are results rather than times (the recovery bench's baseline
fitness, the energy bench's GA best J: the same spec and seed on every host) and shows
them by CPU."""

from __future__ import annotations

from app.core.host import machine_text
from app.jobs.reporting import Section, md_table, missing
from app.results.verify import ABS_TOL, REL_TOL

JSON = "docs/reproducibility.json"
COMMAND = "gaitmend reproduce machines --write-docs"
BENCH_JSON = "docs/benchmarks.json"
BENCH_COMMAND = "gaitmend reproduce bench --write-docs"
OUTCOME_TEXT = {"identical": "identical", "within_tolerance": "within tolerance", "different": "**different**"}
# docs/benchmarks.json figures that are results of a fixed spec and seed, not times
BENCH_RESULTS = (("recovery", "recovery", "paper.fitness", "Recovery bench, the paper DE's best F (legs 1 & 6, seed 0: "
                                                           "the default job's whole search)"),
                 ("recovery", "recovery", "baseline_fitness", "Recovery bench, the baseline gait's F"),
                 ("energy", "energy", "ga_best_J", "Energy bench, the GA's best J (40 x 41, seed 0)"))


def _at(d: dict | None, path: str):
    for k in path.split("."):
        d = d.get(k) if isinstance(d, dict) else None
    return d


def _made(r: dict) -> str:
    return machine_text(r["made_on"], cores=False) if r.get("made_on") else "not recorded"


def _same_cpu(r: dict) -> bool:
    return bool(r.get("made_on")) and machine_text(r["made_on"], cores=False) == machine_text(r["machine"], cores=False)


# the switches a re-run may be forced with: (its field in a row, the environment variable, what it does)
SWITCHES = (("blas_forced", "OPENBLAS_CORETYPE", "numpy's BLAS kernels forced to others"),
            ("numpy_simd_disabled", "NPY_DISABLE_CPU_FEATURES", "numpy's SIMD targets switched off"))


def kernels(blas: list[dict]) -> list[str]:
    """The kernels of threadpoolctl's rows (``openblas Haswell``), the BLAS chose by the CPU
    or OPENBLAS_CORETYPE."""
    return sorted({f"{b['internal_api']} {b['architecture']}" for b in blas if b.get("architecture")})


def _blas(r: dict) -> str:
    """The kernels numpy's BLAS chose on the re-run's CPU (threadpoolctl's architecture)."""
    return ", ".join(kernels(r.get("blas", []))) or "-"


def _forced(r: dict) -> bool:
    return any(r.get(key) for key, _, _ in SWITCHES)


def _kernels_text(r: dict) -> str:
    """BLAS kernels, then numpy's SIMD targets (where recorded), each with what was forced."""
    out = _blas(r) + (f" (forced: OPENBLAS_CORETYPE={r['blas_forced']})" if r.get("blas_forced") else "")
    if "numpy_simd" in r:
        out += "; numpy " + (" ".join(r["numpy_simd"]) or "baseline only")
        if r.get("numpy_simd_disabled"):
            out += f" (NPY_DISABLE_CPU_FEATURES={r['numpy_simd_disabled']})"
    return out


def _counts(rows: list[dict]) -> str:
    c = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOME_TEXT}
    return (f"{len(rows)} re-run{'s' if len(rows) != 1 else ''}, {c['identical']} identical, "
            f"{c['within_tolerance']} within tolerance, {c['different']} different")


COMPARED = ("outcome", "numbers", "differing", "max_rel", "max_abs", "where", "first")


def _switch(r: dict) -> str:
    return "; ".join(f"{env}={r[key]}" for key, env, _ in SWITCHES if r.get(key))


def switches(runs: list[dict]) -> str:
    """What each switch did: a forced re-run against the unforced re-run of the same
    reference on the same CPU model with the same versions. The comparison with the
    reference is kept whole (outcome, counts, largest differences, first difference): where
    it is unchanged the switch changed nothing the reference sees."""
    said = []
    for switch in dict.fromkeys(_switch(r) for r in runs if _forced(r)):
        kept, changed = [], []
        for f in (r for r in runs if _forced(r) and _switch(r) == switch):
            base = next((r for r in runs if not _forced(r) and r["reference"] == f["reference"]
                         and machine_text(r["machine"], cores=False) == machine_text(f["machine"], cores=False)
                         and r["versions"] == f["versions"]), None)
            if base is None:
                continue
            if all(base.get(k) == f.get(k) for k in COMPARED):
                kept.append(f["reference"])
            else:
                same = base["outcome"] == f["outcome"]
                changed.append(f"{f['reference']} ({OUTCOME_TEXT[base['outcome']].strip('*')} -> "
                               f"{OUTCOME_TEXT[f['outcome']].strip('*')}{', other numbers' if same else ''})")
        if kept or changed:
            said.append(f"`{switch}` changes the comparison of {', '.join(changed) or 'no reference'} and leaves "
                        f"{', '.join(kept) or 'none'} exactly as the unforced re-run compared")
    if not said:
        return ""
    return ("\nEach switch against the unforced re-run of the same reference on the same CPU model and versions "
            "(the comparison with the reference whole: outcome, counts, largest and first difference): "
            + "; ".join(said) + ".\n")


def render_table(data: dict | None) -> str:
    runs = (data or {}).get("runs", [])
    if not runs:
        return missing(JSON, COMMAND)
    rows = []
    for r in runs:
        diff = ("-" if r["outcome"] == "identical" else
                f"{r['differing']:,} of {r['numbers']:,}; largest relative {r['max_rel']:.2g} at `{r['where']}`"
                if r["where"] else f"{r['other']} other")
        rows.append([r["reference"], _made(r), r["made_commit"][:10], machine_text(r["machine"], cores=False),
                     r["commit"][:10], f"mujoco {r['versions']['mujoco']}, numpy {r['versions']['numpy']}",
                     _kernels_text(r),
                     OUTCOME_TEXT[r["outcome"]] + ("" if not _same_cpu(r) else " (same CPU)"), diff])
    cross = [r for r in runs if r.get("made_on") and not _same_cpu(r) and not _forced(r)]
    tail = (f"Across CPU models, each CPU's own BLAS kernels and SIMD targets: {_counts(cross)}." if cross else
            "No reference has been re-run on a CPU model other than its maker's yet: the next run "
            f"of `{COMMAND}` on another machine appends its rows.")
    for key, env, what in SWITCHES:
        forced = [r for r in runs if r.get(key) and _same_cpu(r)]
        if forced:
            tail += f" On the maker's own CPU with {what} ({env}, nothing else changed): {_counts(forced)}."
    return (md_table(["reference", "made on", "made at", "re-run on", "re-run at", "versions (re-run)",
                      "BLAS kernels; numpy SIMD (re-run)", "outcome", "numbers that differ"], rows)
            + f"\nEach row re-runs one reference result from its manifest and compares every number of result.json "
              f"(wall-clock figures excepted): identical bit for bit, within tolerance (every number within "
              f"{REL_TOL:g} relative or {ABS_TOL:g} absolute), or different. {tail}\n" + switches(runs))


def render_bench(data: dict | None) -> str:
    runs = (data or {}).get("runs", [])
    rows, seen = [], set()
    for kind, group, key, label in BENCH_RESULTS:
        for r in runs:
            v = _at(r.get("figures", {}).get(group), key)
            m = r.get("machine") or {}
            if r.get("kind") != kind or v is None or "cpu_family" not in m:
                continue
            cpu = machine_text(m, cores=False)
            if (key, cpu, v) not in seen:
                seen.add((key, cpu, v))
                rows.append([label, cpu, repr(v), r["commit"][:10]])
    if not rows:
        return missing(BENCH_JSON, BENCH_COMMAND)
    values = {key: {row[2] for row in rows if row[0] == label} for _, _, key, label in BENCH_RESULTS}
    cpus = {key: {row[1] for row in rows if row[0] == label} for _, _, key, label in BENCH_RESULTS}
    said = "; ".join(f"{label}: {len(values[key])} distinct value{'s' if len(values[key]) != 1 else ''} on "
                     f"{len(cpus[key])} CPU model{'s' if len(cpus[key]) != 1 else ''}"
                     for _, _, key, label in BENCH_RESULTS if cpus[key])
    return (md_table(["figure", "CPU", "value", "commit"], rows)
            + f"\nEach distinct (figure, CPU, value) once, from every bench run that recorded its CPU's family and "
              f"model. {said}.\n")


def sections() -> tuple[Section, ...]:
    return (Section("reproducibility", (JSON,), lambda d: render_table(d[0])),
            Section("reproducibility-bench", (BENCH_JSON,), lambda d: render_bench(d[0])))

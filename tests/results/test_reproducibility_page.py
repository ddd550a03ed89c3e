"""docs/reproducibility.md's tables (issue 45): a re-run on the reference's own CPU model is
marked as such and never counted as a cross-machine result; the bench table shows each
(figure, CPU, value) once and counts the distinct values."""

from __future__ import annotations

from app.cli.machines import reference_name
from app.results import reproducibility as R

INTEL = {"cpu": "Intel(R) Xeon(R) Processor", "cpu_family": 6, "cpu_model": 207, "cores": 2, "python": "3.11.7"}
AMD = {"cpu": "AMD EPYC", "cpu_family": 25, "cpu_model": 17, "cores": 2, "python": "3.11.7"}


def _row(machine, outcome="identical", differing=0, where=None):
    return {"reference": "first-command", "made_on": INTEL, "made_commit": "a" * 40, "machine": machine,
            "commit": "b" * 40, "versions": {"mujoco": "3.3.0", "numpy": "2.2.0"}, "outcome": outcome,
            "numbers": 900, "differing": differing, "other": 0, "max_rel": 0.05 if differing else 0.0,
            "where": where}


def test_same_cpu_rows_are_not_cross_machine_evidence():
    text = R.render_table({"runs": [_row(INTEL)]})
    assert "identical (same CPU)" in text and "No reference has been re-run on a CPU model other" in text
    text = R.render_table({"runs": [_row(INTEL), _row(AMD, "different", 312, "best.fitness")]})
    assert ("Across CPU models, each CPU's own BLAS kernels and SIMD targets: 1 re-run, 0 identical, 0 within "
            "tolerance, 1 different.") in text
    assert "312 of 900; largest relative 0.05 at `best.fitness`" in text and "**different**" in text


def test_forced_kernels_are_the_control_never_a_cross_machine_result():
    same = _row(INTEL, "different", 40, "best.fitness") | {"blas_forced": "Sandybridge",
                                                           "blas": [{"internal_api": "openblas",
                                                                     "architecture": "Sandybridge"}]}
    other = _row(AMD, "different", 312, "best.fitness") | {"blas_forced": "Sandybridge"}
    text = R.render_table({"runs": [_row(AMD, "identical"), same, other]})
    assert "openblas Sandybridge (forced: OPENBLAS_CORETYPE=Sandybridge)" in text
    # the forced row on another CPU is in neither count; the one on the maker's CPU is the control
    assert ("Across CPU models, each CPU's own BLAS kernels and SIMD targets: 1 re-run, 1 identical, 0 within "
            "tolerance, 0 different.") in text
    assert "forced to others (OPENBLAS_CORETYPE, nothing else changed): 1 re-run, 0 identical, 0 within " \
           "tolerance, 1 different." in text
    simd = _row(INTEL, "within_tolerance", 3, "best.fitness") | {"numpy_simd": [], "numpy_simd_disabled": "X86_V3"}
    text = R.render_table({"runs": [_row(AMD, "identical"), simd]})
    assert "numpy baseline only (NPY_DISABLE_CPU_FEATURES=X86_V3)" in text
    assert "switched off (NPY_DISABLE_CPU_FEATURES, nothing else changed): 1 re-run, 0 identical, 1 within" in text
    assert "BLAS kernels and SIMD targets: 1 re-run, 1 identical" in text


def test_a_switch_is_judged_against_the_unforced_rerun_on_the_same_cpu():
    base = _row(AMD, "different", 312, "best.fitness") | {"first": "best.fitness: 1 vs 2"}
    kept = base | {"blas_forced": "Sandybridge"}
    moved = base | {"numpy_simd_disabled": "X86_V3", "differing": 311}
    text = R.switches([base, kept, moved])
    assert "`OPENBLAS_CORETYPE=Sandybridge` changes the comparison of no reference and leaves first-command" in text
    assert "`NPY_DISABLE_CPU_FEATURES=X86_V3` changes the comparison of first-command (different -> different, " \
           "other numbers)" in text
    assert R.switches([kept]) == ""  # no unforced re-run on that CPU to judge it against
    other_cpu = base | {"machine": INTEL}
    assert R.switches([other_cpu, kept]) == ""


def test_a_rerun_under_other_kernels_is_not_skipped(monkeypatch):
    from app.cli import machines as M

    here = M.machine()
    kernels = [{"internal_api": "openblas", "architecture": "Haswell"}]
    row = {"reference": "first-command", "machine": here, "blas": kernels,
           "versions": dict(zip(("mujoco", "numpy"), M._stack()))}
    monkeypatch.setattr(M, "blas", lambda: kernels)
    assert M._done_here({"runs": [row]}, "first-command")
    monkeypatch.setenv("NPY_DISABLE_CPU_FEATURES", "X86_V3")
    assert not M._done_here({"runs": [row]}, "first-command")
    monkeypatch.delenv("NPY_DISABLE_CPU_FEATURES")
    monkeypatch.setattr(M, "blas", lambda: [{"internal_api": "openblas", "architecture": "Sandybridge"}])
    assert not M._done_here({"runs": [row]}, "first-command")
    assert not M._done_here({"runs": [row]}, "tipping-70afe1fd")


def test_the_bench_table_counts_distinct_values_by_cpu():
    runs = [{"kind": "recovery", "machine": m, "commit": "c" * 40,
             "figures": {"recovery": {"paper": {"fitness": f}, "baseline_fitness": -0.067}}}
            for m, f in ((INTEL, 12.38), (AMD, 12.38), (AMD, 12.38), ({"cpu": "x"}, 13.04))]
    text = R.render_bench({"runs": runs})
    assert text.count("| 12.38 |") == 2 and "13.04" not in text  # a run without family and model is left out
    assert "the default job's whole search): 1 distinct value on 2 CPU models" in text
    runs[1]["figures"]["recovery"]["paper"]["fitness"] = 13.04
    assert "whole search): 2 distinct values on 2 CPU models" in R.render_bench({"runs": runs})


def test_reference_folders_are_named_by_kind_and_spec():
    assert reference_name({"key": "first-command"}) == "first-command"
    a = reference_name({"key": '{"kind":"tipping"}', "kind": "tipping"})
    assert a.startswith("tipping-") and len(a) == len("tipping-") + 8
    assert a != reference_name({"key": '{"kind":"tipping","seed":1}', "kind": "tipping"})

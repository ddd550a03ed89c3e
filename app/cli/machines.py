"""`gaitmend reproduce machines`: does a result reproduce on this machine (issue 45)?

The references are the README's example jobs (app/cli/examples.py reads them from
README.md: the first command's default job and one line per kind), each run once and
committed as a bundle's two files, ``manifest.json`` (its spec, seed, versions and the
machine that ran it) and ``result.json``, under docs/reproducibility/<name>/. Each run of
this command re-runs every reference not yet re-run on this CPU model with these versions,
BLAS kernels and numpy SIMD targets, compares every number as `gaitmend verify` does
(app/results/verify.py) and appends the comparison, the machine, its BLAS, numpy's SIMD
targets, what was forced (OPENBLAS_CORETYPE, NPY_DISABLE_CPU_FEATURES: the controls) and
the versions to docs/reproducibility.json, one reference at a time (an interruption loses
only the one under way). A missing reference is
made first, on this machine. app/results/reproducibility.py renders the file."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from pydantic import Field

from app.cli.bench import _names, append_measured, measured
from app.cli.common import default_spec_data
from app.cli.examples import FIRST_KEY, ExampleKinds, parse_examples, parse_first
from app.core.host import machine, machine_text
from app.jobs.base import Experiment, MemoryContext, dumps
from app.jobs.ledger import ROOT, write_json_atomic
from app.jobs.registry import get_kind, parse_spec
from app.results import reproducibility as rendered


class MachinesParams(ExampleKinds):
    kinds: str = Field("", description="only the README examples of these kinds, comma-separated ('first': the first "
                                       "command's job); empty: every example")
    references: str = Field("docs/reproducibility", description="the folder of the committed reference results, one "
                                                                "folder each (relative: to the repository)")
    json_out: Path = Field(Path(rendered.JSON), description="the file each comparison is appended to")


def reference_name(example: dict) -> str:
    """A reference's folder: ``first-command``, or the kind and the first 8 hex digits of
    its spec's hash (``recovery-1a2b3c4d``)."""
    if example["key"] == FIRST_KEY:
        return FIRST_KEY
    return f"{example['kind']}-{hashlib.sha256(example['key'].encode()).hexdigest()[:8]}"


def _spec_of(example: dict):
    return parse_spec(default_spec_data() if example["key"] == FIRST_KEY else json.loads(example["spec"]))


def _run(spec) -> tuple:
    """(the job's result, the result.json a bundle of it holds) of a fresh local run of ``spec``."""
    from app.results.bundle import _finite

    with tempfile.TemporaryDirectory() as tmp:
        result = get_kind(spec.kind).run(spec, MemoryContext(Path(tmp)))
    return result, _finite(json.loads(dumps(result.summary)))


def make_reference(example: dict, folder: Path, log: Callable[[str], None]) -> None:
    from app.results.bundle import manifest

    spec = _spec_of(example)
    log(f"{folder.name}: making the reference here ({example['command']})")
    result, summary = _run(spec)
    folder.mkdir(parents=True, exist_ok=True)
    write_json_atomic(folder / "result.json", summary)
    write_json_atomic(folder / "manifest.json", manifest(folder.name, spec, result))


def blas() -> list[dict]:
    """numpy's BLAS and OpenMP libraries as threadpoolctl finds them: API, version, threads."""
    from threadpoolctl import threadpool_info

    return [{k: i.get(k) for k in ("internal_api", "version", "num_threads", "architecture")} for i in threadpool_info()]


def verify_reference(example: dict, folder: Path) -> dict:
    from app.results.bundle import versions
    from app.results.verify import compare

    man = json.loads((folder / "manifest.json").read_text())
    saved = json.loads((folder / "result.json").read_text())
    _, fresh = _run(parse_spec(man["spec"]))
    v = versions()
    return {"reference": folder.name, "kind": man["kind"], "spec": example["spec"], "made_on": man.get("machine"),
            "made_commit": man["versions"]["commit"],
            "made_versions": {k: man["versions"].get(k) for k in ("mujoco", "numpy", "scipy", "python")},
            "versions": {k: v[k] for k in ("mujoco", "numpy", "scipy", "python")}, "blas": blas(),
            "numpy_simd": numpy_simd(), **_forced(),
            **compare(saved, fresh).to_json()}


def numpy_simd() -> list[str]:
    """numpy's SIMD dispatch targets this CPU runs (``X86_V3``, ``X86_V4``, ...): its ufuncs
    (exp, sin, ...) choose their code by them at run time, as its BLAS chooses its kernels;
    NPY_DISABLE_CPU_FEATURES switches targets off."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return [t for t in __cpu_dispatch__ if __cpu_features__.get(t)]


def _forced() -> dict:
    """What this run forced on numpy, by the switches' fields (None each: the CPU's own choice)."""
    return {key: os.environ.get(env) or None for key, env, _ in rendered.SWITCHES}


def _done_here(data: dict, name: str) -> bool:
    """Re-run here already: this CPU model, these versions, these BLAS kernels (on one CPU,
    OPENBLAS_CORETYPE changes them) and the same numpy SIMD targets switched off."""
    here, v, kernels, off = machine_text(machine(), cores=False), _stack(), rendered.kernels(blas()), _forced()
    return any(r["reference"] == name and machine_text(r["machine"], cores=False) == here
               and (r["versions"]["mujoco"], r["versions"]["numpy"]) == v
               and rendered.kernels(r.get("blas", [])) == kernels
               and r.get("numpy_simd_disabled") == off["numpy_simd_disabled"] for r in data.get("runs", []))


def _stack() -> tuple[str, str]:
    from app.results.bundle import versions

    return versions()["mujoco"], versions()["numpy"]


def reproduce_machines(p: MachinesParams, log: Callable[[str], None] = print) -> str:
    text = (ROOT / "README.md").read_text()
    examples = [parse_first(text), *parse_examples(text)]
    wanted = _names(p.kinds)
    examples = [e for e in examples if not wanted or ("first" if e["key"] == FIRST_KEY else e["kind"]) in wanted]
    base = ROOT / p.references if not Path(p.references).is_absolute() else Path(p.references)
    data = json.loads(p.json_out.read_text()) if p.json_out.exists() else {}
    todo = []
    for e in examples:
        folder = base / reference_name(e)
        if not (folder / "result.json").exists():
            make_reference(e, folder, log)
        if not _done_here(data, folder.name):
            todo.append(e)
    data = append_measured(p.json_out, "machines", rendered.COMMAND, todo,
                           lambda e: measured(lambda: verify_reference(e, base / reference_name(e))),
                           lambda e: f"{reference_name(e)}: re-run and compared", log)
    if not todo:
        log("every reference has been re-run on this CPU model with these versions, BLAS kernels and numpy "
            f"SIMD targets ({p.json_out})")
    return rendered.render_table(data)


EXPERIMENT = Experiment("machines",
                        "whether the README's example jobs reproduce on this machine: each committed reference "
                        "result (docs/reproducibility/) re-run and compared number by number as `gaitmend verify` "
                        "does (identical, within tolerance, different), appended with the machine, its BLAS and the "
                        "versions; references already re-run on this CPU model with these versions, BLAS "
                        "kernels and numpy SIMD targets are skipped",
                        MachinesParams, reproduce_machines, rendered.sections())

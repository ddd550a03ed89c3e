"""`gaitmend study run`: every point in a process pool on this machine, no server. The
summaries go through the same JSON round trip as a worker's, so the aggregate equals the
served one."""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, Callable

from app.studies.spec import Plan


def run_point(spec_dict: dict, bundle: str | None = None) -> tuple[str, dict | None, str | None]:
    """Run one point as a job would; with ``bundle`` (a .zip path) also write its job
    bundle there, as a worker does."""
    from app.jobs.base import MemoryContext, dumps
    from app.jobs.registry import get_kind, parse_spec

    try:
        spec = parse_spec(spec_dict)
        with tempfile.TemporaryDirectory() as tmp:
            res = get_kind(spec.kind).run(spec, MemoryContext(Path(tmp)))
        if bundle is not None:
            from app.results.bundle import write_bundle

            write_bundle(Path(bundle), Path(bundle).stem, spec, res)
        return "succeeded", json.loads(dumps(res.summary)), None
    except Exception as e:  # a point that fails is listed with its error; the others go on
        return "failed", None, f"{type(e).__name__}: {e}"


def _one_thread() -> None:
    # One BLAS/OpenMP thread per process: the pool is the parallelism.
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "GAITMEND_SIM_THREADS"):
        os.environ[k] = "1"


def run_plan(plan: Plan, workers: int | None = None, log: Callable[[str], None] = lambda s: None,
             bundle_dir: Path | None = None) -> list[dict[str, Any]]:
    """Every point, in ``workers`` processes (1: in this process). With ``bundle_dir``, each
    point's job bundle is written there as point-NNNN.zip."""
    workers = max(1, min(workers or os.cpu_count() or 1, len(plan.points)))
    rows: dict[int, dict[str, Any]] = {}
    if bundle_dir is not None:
        bundle_dir.mkdir(parents=True, exist_ok=True)

    def bundle(p) -> str | None:
        return None if bundle_dir is None else str(bundle_dir / f"point-{p['index']:04d}.zip")

    if workers == 1:
        for p in plan.points:
            status, summary, error = run_point(p["spec"], bundle(p))
            rows[p["index"]] = p | {"status": status, "summary": summary, "error": error}
            log(f"point {p['index'] + 1}/{len(plan.points)} {status}")
    else:
        ctx = mp.get_context("spawn")
        with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_one_thread) as pool:
            futs = {pool.submit(run_point, p["spec"], bundle(p)): p for p in plan.points}
            for n, f in enumerate(as_completed(futs), 1):
                p = futs[f]
                status, summary, error = f.result()
                rows[p["index"]] = p | {"status": status, "summary": summary, "error": error}
                log(f"point {n}/{len(plan.points)} {status}")
    return [rows[i] for i in sorted(rows)]

"""`gaitmend bench --kind repertoire`: how fast the evaluator scores gaits, against raw
rollout throughput (issue 43: the evaluator at >= 0.9 of raw ``mujoco.rollout``).

Both sides run the same batch of uniform random gaits of the default spec's robot (the
intact hexapod) for the default trial, on the same ``Rollout`` threads:

- raw: the gait's part of the trial from the settled state (the settling, the same for
  every gait, is simulated once per evaluator: ``Evaluator.settled``), its set-points
  computed beforehand, then one rollout call (what the simulation alone costs);
- evaluator: ``Evaluator.evaluate`` as the job calls it (set-points per chunk, chunked
  rollouts, the metrics reduced from each chunk's sensor data), its settling already done.

Each is timed ``REPEATS`` times, alternating, and the best of each is kept (the least
disturbed by other load on a shared machine), in wall time and in CPU time of this
process (``cpu_ratio``: on a machine shared with other work the wall-time ratio of a few
repeats swings both ways; the CPU time counts only this process's own work)."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from app.jobs.base import BenchEntry

TARGET_RATIO = 0.9
MAP_GAITS, TARGET_MAP_MIN = 100_000, 30.0  # issue 43: a hexapod map of 100,000 gaits in at most 30 min on two cores
REPEATS = 3


def bench_repertoire(quick: bool = False, log: Callable[[str], None] = print) -> dict:
    from app.jobs.registry import parse_spec
    from app.jobs.repertoire.body import build
    from app.jobs.repertoire.evaluate import Evaluator
    from app.jobs.repertoire.run import layout_of

    spec = parse_spec({"kind": "repertoire"})
    # one iteration's batch: the emitter's gaits and the random control's
    batch = 2 * spec.search.batch_size if not quick else 40
    duration = spec.sim.duration_s if not quick else 1.0
    body = build(spec)
    layout = layout_of(spec, body)
    ev = Evaluator(body, layout, duration, spec.sim.settle_s)
    x = np.random.default_rng(0).uniform(size=(batch, layout.dim))
    raw_s, eval_s, raw_cpu, eval_cpu = [], [], [], []
    try:
        ctrl = ev.controls(x, ev.n_settle, ev.nstep)
        state = np.repeat(ev.settled()[0][None], batch, axis=0)
        for _ in range(REPEATS):
            t0, c0 = time.perf_counter(), time.process_time()
            ev._rollout(state, ctrl)  # noqa: SLF001 (the evaluator's own threads and buffers)
            raw_s.append(time.perf_counter() - t0)
            raw_cpu.append(time.process_time() - c0)
            t0, c0 = time.perf_counter(), time.process_time()
            ev.evaluate(x)
            eval_s.append(time.perf_counter() - t0)
            eval_cpu.append(time.process_time() - c0)
    finally:
        ev.close()
    raw, evaluator = min(raw_s), min(eval_s)
    steps = batch * ev.n_walk
    ratio = raw / evaluator
    cpu_ratio = min(raw_cpu) / min(eval_cpu)  # CPU seconds of this process's threads: less swayed by other load
    # the same map on two cores of its own: the evaluator's CPU seconds per gait shared by its threads (a
    # projection: it assumes the threads run side by side, as they do on an idle machine)
    minutes_cpu = MAP_GAITS * min(eval_cpu) / batch / ev.nthread / 60
    minutes = MAP_GAITS / (batch / evaluator) / 60  # the evaluator's rate alone: the archive's work is not timed
    log(f"repertoire: {batch} gaits x {ev.n_walk} steps: raw {raw:.2f} s, evaluator {evaluator:.2f} s, ratio {ratio:.3f}")
    return {"batch": batch, "steps_per_gait": ev.n_walk, "timestep_s": ev.dt, "threads": ev.nthread,
            "parameters": layout.dim,
            "raw_rollout_s": raw, "evaluator_s": evaluator, "raw_steps_per_s": steps / raw,
            "evaluator_steps_per_s": steps / evaluator, "evaluations_per_s": batch / evaluator, "ratio": ratio,
            "map_100k_min": minutes, "raw_cpu_s": min(raw_cpu), "evaluator_cpu_s": min(eval_cpu),
            "cpu_ratio": cpu_ratio, "map_100k_min_cpu": minutes_cpu,
            "targets": {"ratio_min": TARGET_RATIO, "ratio_met": bool(ratio >= TARGET_RATIO),
                        "cpu_ratio_min": TARGET_RATIO, "cpu_ratio_met": bool(cpu_ratio >= TARGET_RATIO),
                        "map_100k_min_max": TARGET_MAP_MIN, "map_100k_min_met": bool(minutes <= TARGET_MAP_MIN),
                        "map_100k_min_cpu_max": TARGET_MAP_MIN,
                        "map_100k_min_cpu_met": bool(minutes_cpu <= TARGET_MAP_MIN)}}


BENCH = [BenchEntry("repertoire", "gaits scored per second by the batched evaluator, and its ratio to raw rollout "
                    "throughput (target >= 0.9)", bench_repertoire)]

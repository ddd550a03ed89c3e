"""How many threads one job's rollouts may use.

GAITMEND_SIM_THREADS when set; otherwise the CPUs this process may run on. `gaitmend
worker` sets it to cores / concurrency for its pool, and `gaitmend study run` to 1 per
process, so N jobs side by side do not each start one thread per core (N x cores threads
on cores CPUs). Results do not depend on it: every rollout's numbers are the same with any
thread count (tests/sim)."""

from __future__ import annotations

import os

ENV = "GAITMEND_SIM_THREADS"


def available_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def sim_threads() -> int:
    v = os.environ.get(ENV, "").strip()
    if not v:
        return available_cpus()
    try:  # a service checks it at start (app.core.settings); a local run meets it here
        n = int(v)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"{ENV} must be a whole number >= 1, got {v!r}")
    return n

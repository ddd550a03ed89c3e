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
    if v:
        n = int(v)  # validated at start by app.settings (GAITMEND_SIM_THREADS)
        if n >= 1:
            return n
    return available_cpus()

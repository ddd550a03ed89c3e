"""Rollout threads per job: GAITMEND_SIM_THREADS, else the CPUs this process may use."""

from __future__ import annotations

import os

import pytest

from app.core.settings import SettingsError, load_settings
from app.sim.threads import ENV, available_cpus, sim_threads


def test_unset_means_every_cpu_this_process_may_use(monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    assert sim_threads() == available_cpus() == len(os.sched_getaffinity(0))


def test_the_variable_sets_it(monkeypatch):
    monkeypatch.setenv(ENV, "3")
    assert sim_threads() == 3


@pytest.mark.parametrize("bad", ["0", "-2", "many"])
def test_a_bad_value_stops_the_service_and_a_local_run_with_its_name(monkeypatch, bad):
    monkeypatch.setenv(ENV, bad)
    with pytest.raises(SettingsError, match="GAITMEND_SIM_THREADS"):
        load_settings()
    with pytest.raises(ValueError, match="GAITMEND_SIM_THREADS must be a whole number >= 1"):
        sim_threads()

"""What the tests observe, kept as data (app/results/observed.py): recorded only where
GAITMEND_OBSERVED names a file outside the checkout, appended under a lock, rendered as the
latest run of each figure with the earlier ones counted."""

from __future__ import annotations

import json
import multiprocessing

import pytest

from app.results import observed


def test_nothing_is_written_without_the_variable(tmp_path, monkeypatch):
    monkeypatch.delenv(observed.ENV, raising=False)
    assert observed.record("dashboard.first_plot_s", [5.0]) is False
    assert list(tmp_path.iterdir()) == []


def test_a_record_carries_its_test_machine_and_commit(tmp_path, monkeypatch):
    path = tmp_path / "o.json"
    monkeypatch.setenv(observed.ENV, str(path))
    assert observed.record("faults.redis_queue_moved_s", [1.7, 2.6], {"restarts": 2}) is True
    row = json.loads(path.read_text())["runs"][0]
    assert row["figure"] == "faults.redis_queue_moved_s" and row["values"] == [1.7, 2.6]
    assert row["setup"] == {"restarts": 2} and row["test"].endswith("test_a_record_carries_its_test_machine_and_commit")
    assert row["machine"]["cores"] >= 1 and isinstance(row["load"], float) and row["date"].endswith("UTC")


@pytest.mark.parametrize("figure, values, match", [
    ("faults.not_a_figure", [1.0], "not declared"),
    ("dashboard.first_plot_s", [], "non-empty"),
    ("dashboard.first_plot_s", [float("nan")], "finite"),
    ("dashboard.first_plot_s", [True], "finite"),
    ("dashboard.first_plot_s", ["1.0"], "finite"),
])
def test_bad_figures_are_refused(tmp_path, figure, values, match):
    with pytest.raises(ValueError, match=match):
        observed.record(figure, values, path=str(tmp_path / "o.json"))
    assert not (tmp_path / "o.json").exists()


def test_the_checkout_is_refused():
    with pytest.raises(ValueError, match="inside the checkout"):
        observed.record("dashboard.first_plot_s", [1.0], path=str(observed.ROOT / "docs" / "observed_x.json"))
    assert not (observed.ROOT / "docs" / "observed_x.json").exists()


def _append(args):
    path, i = args
    observed.record("faults.pg_backends_per_burst", [float(i)], path=path)


def test_processes_appending_at_once_lose_nothing(tmp_path):
    path = str(tmp_path / "o.json")
    with multiprocessing.get_context("spawn").Pool(3) as pool:
        pool.map(_append, [(path, i) for i in range(24)])
    got = sorted(r["values"][0] for r in json.loads((tmp_path / "o.json").read_text())["runs"])
    assert got == [float(i) for i in range(24)]


def test_the_page_shows_the_latest_run_of_each_figure(tmp_path):
    path = str(tmp_path / "o.json")
    observed.record("faults.stop_worker_exit_s", [0.5, 0.9], path=path)
    observed.record("faults.stop_worker_exit_s", [0.7, 1.3, 1.1], {"rounds": 3}, path=path)
    observed.record("faults.pg_backends_per_burst", [52, 70], path=path)
    observed.record("dashboard.first_plot_s", [4.9], path=path)
    data = json.loads((tmp_path / "o.json").read_text())
    faults = observed.render(data, "faults")
    assert "0.7-1.3 s (3 values)" in faults and "0.5-0.9" not in faults and "rounds 3" in faults
    assert "52-70 (2 values)" in faults and "first_plot" not in faults
    assert "1 earlier record kept" in faults
    service = observed.render(data, "service")
    assert "| 4.9 s |" in service and "0 earlier records" in service
    assert "No data yet" in observed.render({"runs": []}, "faults")

"""`gaitmend reproduce repertoire` in small (seconds): MAP-Elites and the random search per
robot (the built-in hexapod and Gymnasium's Ant uploaded from its wheel) and seed, each
finished run appended to the ledger; a re-run skips them; a reproduction killed between
runs continues to the same file; a run killed midway resumes from its checkpoint file to
the same numbers; the page's tables are rendered from the JSON with the budget each row had.
And the emitter experiment's small paired comparison."""

from __future__ import annotations

import json

import pytest

from app.jobs.repertoire.reproduce import experiments as ex
from app.jobs.repertoire.reproduce import runs

TINY = dict(evaluations=12, seeds="0,1", robots="jethexa,gym_ant", batch_size=6, cells=12, duration_s=0.2,
            timestep_s=0.004, rescore_elites=2, held_out_elites=2, history_points=3)


def _results(path) -> dict:
    data = json.loads(path.read_text())
    out = {}
    for r in data["runs"]:
        res = dict(r["result"])
        res.pop("timing")
        res["held_out"] = {k: v for k, v in res["held_out"].items() if k != "wall_s"}
        out[r["name"]] = res
    return out


@pytest.fixture(scope="module")
def ledger(tmp_path_factory):
    path = tmp_path_factory.mktemp("rep") / "evidence.json"
    text = ex._evidence(ex.EvidenceParams(**TINY, json_out=path, checkpoints=path.parent / "ck"), log=lambda m: None)
    return path, text


def test_each_robot_and_seed_is_one_run_with_both_arms_at_the_stated_budget(ledger):
    path, text = ledger
    data = json.loads(path.read_text())
    assert [r["name"] for r in data["runs"]] == ["jethexa seed 0", "gym_ant seed 0", "jethexa seed 1", "gym_ant seed 1"]
    for r in data["runs"]:
        res = r["result"]
        assert res["budget"]["evaluations_per_arm"] == 12 and res["budget"]["iterations"] == 2
        assert set(res["arms"]) == {"map_elites", "random"}
        assert res["convergence"][-1]["evaluations"] == 12 and "random_qd_score" in res["convergence"][-1]
        assert res["held_out"]["elites"] == 2 and [c["name"] for c in res["held_out"]["cases"]] == list(
            runs.HELD_OUT_CASES)
        assert res["timing"]["evaluations"] == 2 * 12 + 2 + 1  # both arms, the re-scorings, the recorded walk
    ant = next(r for r in data["runs"] if r["name"] == "gym_ant seed 0")
    assert len(ant["spec"]["robot"]) == 32 and ant["result"]["robot_info"]["built_in"] is False
    assert "Gymnasium Ant (uploaded)" in text and "jethexa (built-in hexapod)" in text
    assert "| 0, 1 | 12 | 12 |" in text  # the seeds, the budget each row had and the cells are printed
    assert "Held-out models" in text and "Timestep check" in text and "Convergence" in text
    assert ex.render_evidence([data]) == text  # the page is the JSON rendered


def test_a_rerun_skips_the_finished_runs(ledger):
    path, _ = ledger
    before = path.read_text()
    logs = []
    ex._evidence(ex.EvidenceParams(**TINY, json_out=path, checkpoints=path.parent / "ck"), log=logs.append)
    assert sum("skipped" in m for m in logs) == 4 and path.read_text() == before


def test_a_reproduction_killed_between_runs_continues_to_the_same_numbers(ledger, tmp_path):
    path, _ = ledger
    cut = tmp_path / "cut.json"

    def stop_after_two(m):
        if m.startswith("gym_ant seed 0: done"):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ex._evidence(ex.EvidenceParams(**TINY, json_out=cut, checkpoints=tmp_path / "ck"), log=stop_after_two)
    assert len(json.loads(cut.read_text())["runs"]) == 2
    assert "Partial: 2 of 4" in ex.render_evidence([json.loads(cut.read_text())])
    ex._evidence(ex.EvidenceParams(**TINY, json_out=cut, checkpoints=tmp_path / "ck"), log=lambda m: None)
    assert _results(cut) == _results(path)


def test_a_run_killed_midway_resumes_from_its_checkpoint_file_to_the_same_numbers(tmp_path):
    p = ex.EvidenceParams(**(TINY | {"evaluations": 18}))
    data = ex.evidence_spec(p, "jethexa", 3)
    data["search"]["checkpoint_every"] = 1
    whole = runs.run_one(data, "jethexa", None, None, 2, 3)

    class Killed(runs.FileContext):
        saves = 0

        def save_checkpoint(self, state):
            super().save_checkpoint(state)
            Killed.saves += 1
            if Killed.saves == 2:
                raise KeyboardInterrupt  # kill -9 right after the second checkpoint

    ckpt = tmp_path / "run.json"
    real = runs.FileContext
    runs.FileContext = Killed
    try:
        with pytest.raises(KeyboardInterrupt):
            runs.run_one(data, "jethexa", None, ckpt, 2, 3)
    finally:
        runs.FileContext = real
    resumed = runs.run_one(data, "jethexa", None, ckpt, 2, 3)
    assert resumed["timing"]["resumed_from_iteration"] == 2
    for r in (whole, resumed):
        r.pop("timing")
        r["held_out"].pop("wall_s")
    assert resumed == whole


def test_the_emitter_experiment_pairs_each_step_with_the_random_search(tmp_path):
    path = tmp_path / "emitter.json"
    text = ex._emitter(ex.EmitterParams(evaluations=12, seeds="0,1", iso_sigmas="0.01,0.2", batch_size=6, cells=12,
                                        timestep_s=0.004, duration_s=0.2, json_out=path), log=lambda m: None)
    data = json.loads(path.read_text())
    assert len(data["runs"]) == 4 and sum("random" in r["result"] for r in data["runs"]) == 2
    assert "iso_sigma 0.01" in text and "iso_sigma 0.2" in text and "random search" in text
    assert "Highest mean QD-score" in text

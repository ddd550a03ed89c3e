"""The damage atlas as data (issue 28, app/jobs/recovery/reproduce/atlas_check.py): each (loss, seed) a
real search appended to its ledger and skipped on a re-run, and the page rendered from the
ledger and Table II's rows alone (what it counts, which Table II rows it takes)."""

import json

import pytest

from app.jobs.ledger import Ledger
from app.jobs.recovery.reproduce import atlas_check


@pytest.fixture
def one_loss_one_second(monkeypatch):
    """Legs 2 & 3 only, 1 s walks: the real search on MuJoCo, small enough for a test."""
    spec_of = atlas_check._spec
    monkeypatch.setattr(atlas_check, "_spec", lambda *a: spec_of(*a) | {"sim": {"duration_s": 1.0}})
    monkeypatch.setattr(atlas_check, "atlas_losses", lambda: [(2, 3)])


def test_each_point_is_searched_appended_then_skipped(tmp_path, monkeypatch, one_loss_one_second):
    path = tmp_path / "atlas.json"
    p = atlas_check.AtlasParams(seeds=1, population=4, generations=1, json_out=path)
    logs = []
    atlas_check.run_atlas(p, logs.append)
    data = json.loads(path.read_text())
    assert data["planned"] == 1 and len(data["runs"]) == 1
    run = data["runs"][0]
    res = run["result"]
    assert run["name"] == "legs 2-3 seed 0" and run["code_version"] == data["code_version"] and run["wall_s"] > 0
    assert res["lost_legs"] == [2, 3] and res["population"] == 4 and res["generations"] == 1
    assert res["timestep_s"] == 0.001 and len(res["best_params"]) == 10
    assert res["target_met"] is (False if res["best"]["fell"] else None)  # a 1 s walk is too short to judge
    assert res["robustness"]["total"] == 7 and set(res["robustness"]["cases"]) >= {"dt_half", "dt_quarter"}
    assert set(res["best"]) >= set(atlas_check.KEEP) and "y_f_m" in res["baseline"]
    curve = res["curve"]  # the best F after each generation: never falls, ends at the answer's F
    assert [c[0] for c in curve] == [0, 1] and [c[2] for c in curve] == [4, 8]
    assert curve[0][1] <= curve[1][1] == res["best_fitness"]
    monkeypatch.setattr(atlas_check, "search_one", lambda *a: pytest.fail("a finished point was run again"))
    atlas_check.run_atlas(p, logs.append)
    assert json.loads(path.read_text())["runs"] == data["runs"] and sum("skipped" in m for m in logs) == 1


def _walk(y, x=0.01, yaw=1.0, fell=False):
    return {"x_f_m": x, "y_f_m": y, "yaw_f_deg": yaw, "tilt_max_deg": 2.0, "fell": fell}


def _row(lost, seed, y, met, rob_met, baseline_met=False, population=30, generations=60, half_y=None):
    half = _walk(y if half_y is None else half_y) | {"target_met": met}
    return {"lost_legs": list(lost), "seed": seed, "population": population, "generations": generations,
            "timestep_s": 0.001, "baseline": _walk(0.1), "baseline_target_met": baseline_met, "best": _walk(y),
            "best_fitness": 10.0, "best_params": {}, "target_met": met, "gait": "modified_pentagonal",
            "robustness": {"met": rob_met, "total": 7, "cases": {"dt_half": half}}}


def _ledger(tmp_path, rows, seeds=2):
    led = Ledger(tmp_path / "atlas.json", "recovery-atlas", atlas_check.COMMAND,
                 atlas_check.AtlasParams(seeds=seeds).model_dump(mode="json"), atlas_check.SCIENCE,
                 planned=len(atlas_check.atlas_losses()) * seeds)
    for r in rows:
        led.run(f"legs {r['lost_legs']} seed {r['seed']}", {"lost": r["lost_legs"]}, r["seed"], lambda r=r: r)
    return led.data


def test_the_page_counts_the_rows_and_takes_table_ii_rows_of_the_same_search(tmp_path):
    atlas = _ledger(tmp_path, [_row((2,), 0, 1.10, True, 6, baseline_met=True), _row((2,), 1, 1.20, True, 5),
                               _row((4, 5), 0, 0.80, False, 1, half_y=0.70)])
    table2 = [_row((1, 6), 0, 1.00, True, 4), _row((1, 6), 1, 1.02, True, 5),
              _row((1, 6), 2, 1.04, True, 6),  # seed 2: beyond the atlas's 2 seeds, left out
              _row((3, 4), 0, 1.2, True, 3, population=12)]  # another budget: left out
    md = atlas_check.render([atlas, table2])
    assert "| 2 | 2 | atlas | 115.0 [110.0, 120.0] | 1.0 [1.0, 1.0] | 1.0 [1.0, 1.0] | 2/2 | 0 | **yes** | 6, 5 |" in md
    assert "| 1, 6 | 2 | Table II | 101.0 [100.0, 102.0] |" in md and "| 2/2 | 0 | no | 4, 5 |" in md
    assert "| 4, 5 | 1 | atlas |" in md and "| 3, 4 |" not in md
    assert "**Recovery meets the target in 4 of 5 answers**; missed: legs 4 & 5 (seed 0)." in md
    assert "already meets the target** for: leg 2 " in md
    assert "(single-leg losses): the answers keep the target in a median of 5.5 of 7 [5, 6]" in md
    # the legs 4 & 5 answer moves 12.5 % forward at half the step: the rule fails on it
    assert "over these 5 answers" in md and "**fails**; forward moves at most 12.5 %" in md
    assert "legs 1 & 3, legs 1 & 5, legs 3 & 5 (infeasible morphology" in md
    assert "*Partial: 3 of 22 planned runs" in md and "3 runs" in md


def test_the_page_without_data_says_which_command_writes_it():
    assert "No data yet" in atlas_check.render([None, None])
    md = atlas_check.render([None, [_row((1,), 0, 1.2, True, 6)]])
    assert "| 1 | 1 | Table II |" in md and "No atlas runs yet" in md

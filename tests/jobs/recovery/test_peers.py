"""Issue 28's peers of the paper DE on Table II (app/jobs/recovery/reproduce/peers.py, peers_check.py):
scipy's DE and CMA-ES at our budget appended to their ledger and skipped on a re-run, the
paired statistics of the Table II page, and the page rendered from the files alone."""

import json
from pathlib import Path

import pytest
from app.jobs.recovery.reproduce import experiments, peers, peers_check

ROOT = Path(__file__).resolve().parents[3]


def _table2_row(lost, seed, population, generations, fitness, rs_fitness, y=0.6, rs_y=0.5):
    """A Table II row as run_scenarios writes it (the fields the page reads)."""
    walk = {"x_f_m": 0.01, "y_f_m": y, "yaw_f_deg": 1.0, "fell": False}
    return {"version": experiments.ROW_VERSION, "lost_legs": list(lost), "seed": seed, "generations": generations,
            "population": population, "timestep_s": 0.001, "baseline": walk | {"y_f_m": 0.1},
            "baseline_target_met": False, "best": walk, "best_fitness": fitness, "best_params": {},
            "target_met": True, "random_search": {"metrics": walk | {"y_f_m": rs_y}, "fitness": rs_fitness,
                                                  "target_met": False},
            "robustness": {"met": 1, "total": 1, "cases": {"dt_half": walk | {"target_met": True}}},
            "gait": "modified_pentagonal", "wall_s": 10.0}


@pytest.fixture
def one_second_walks(monkeypatch):
    """Legs 3 & 4 only, 1 s walks: the real searches on MuJoCo, small enough for a test."""
    spec_of = peers.peer_spec
    monkeypatch.setattr(peers, "peer_spec", lambda *a: spec_of(*a) | {"sim": {"duration_s": 1.0}})
    monkeypatch.setattr(peers_check, "SCENARIOS", ((3, 4),))


def test_each_peer_run_is_appended_then_skipped_and_the_page_pairs_it(tmp_path, monkeypatch, one_second_walks):
    path = tmp_path / "peers.json"
    p = peers_check.PeersParams(seeds=1, population=5, generations=1, json_out=path)
    logs = []
    peers_check.run_peers(p, logs.append)
    data = json.loads(path.read_text())
    runs = data["runs"]
    assert [r["result"]["method"] for r in runs] == ["scipy_de", "cmaes"] and data["planned"] == 2
    for r in runs:
        res = r["result"]
        assert r["code_version"] == data["code_version"] and r["seed"] == 0 and res["lost_legs"] == [3, 4]
        assert res["evaluations"] == 5 * 2 == res["budget_walks"]  # population x (generations + 1), as our DE
        assert res["sim_steps"] > 0 and res["timestep_s"] == 0.001 and res["cores"] >= 1
        assert set(res["metrics"]) == set(peers.KEEP) and isinstance(res["target_met"], bool)
        assert res["wall_s"] > 0 and "load_before" in res and len(res["best_params"]) == 10
    # A second call finds both runs at this code version and simulates nothing.
    monkeypatch.setattr(peers, "run_peer", lambda *a: pytest.fail("a finished run was run again"))
    peers_check.run_peers(p, logs.append)
    assert json.loads(path.read_text())["runs"] == runs and sum("skipped" in m for m in logs) == 2
    rows = [_table2_row((3, 4), 0, 5, 1, fitness=runs[0]["result"]["fitness"] + 1.0, rs_fitness=0.1)]
    md = experiments.table_markdown(rows, 1, 5, data)
    assert "| our DE vs scipy DE | legs 3 & 4 | 1 | +1.00 no interval (n < 2) | +1.00 | 1/1 |" in md
    assert "| our DE vs CMA-ES | legs 3 & 4 | 1 |" in md and "| legs 3 & 4 | CMA-ES | 1 |" in md
    assert "F: mean difference [95 % CI]" in md and "forward (cm): mean difference [95 % CI]" in md


def test_ours_against_a_control_is_shown_only_when_the_interval_and_the_test_agree():
    ours = {((1,), s): {"fitness": f, "forward_cm": 60.0} for s, f in enumerate([10, 12, 11, 13, 12])}
    clear = {((1,), s): {"fitness": f, "forward_cm": 60.0} for s, f in enumerate([1, 2, 2, 3, 1])}
    r = peers_check.compare(ours, clear, "fitness", ("our DE", "random search"))
    # differences 9, 10, 9, 10, 11: mean 9.8, sd 0.84, t(4) interval 9.8 -+ 1.04, but the exact
    # signed-rank test of 5 pairs cannot go below 2/2^5 = 0.0625: not shown
    assert r["n"] == 5 and r["wins"] == 5 and r["median_diff"] == 10.0
    assert r["ci"] == pytest.approx([8.76, 10.84], abs=0.01) and r["p"] == pytest.approx(0.0625)
    assert r["verdict"] == "not shown (interval excludes 0, but 5 pairs cannot give Wilcoxon p < 0.05)"
    more = {((1,), s): {"fitness": 10.0 + s % 3, "forward_cm": 60.0} for s in range(6)}
    r = peers_check.compare(more, {k: {"fitness": 1.0, "forward_cm": 60.0} for k in more}, "fitness",
                            ("our DE", "random search"))
    assert r["n"] == 6 and r["p"] == pytest.approx(2 / 2 ** 6) and r["verdict"] == "our DE better (shown)"
    close = {((1,), s): {"fitness": f, "forward_cm": 60.0} for s, f in enumerate([7, 14, 10, 18, 11.5])}
    r = peers_check.compare(ours, close, "fitness", ("our DE", "random search"))
    # differences +3, -2, +1, -5, +0.5: mean -0.5, the interval straddles 0
    assert r["mean_diff"] == -0.5 and r["ci"][0] < 0 < r["ci"][1] and r["verdict"] == "not shown"
    assert r["wins"] == 3 and r["test"].startswith("Wilcoxon signed-rank, two-sided, exact")


def test_twelve_pairs_take_the_bca_bootstrap_and_the_rows_say_not_shown():
    ours = {((1, 6), s): {"fitness": 5.0 + s, "forward_cm": 50.0 + (s % 3)} for s in range(12)}
    ctrl = {((1, 6), s): {"fitness": 3.0 + s + 0.1 * (s % 4), "forward_cm": 51.0} for s in range(12)}
    r = peers_check.compare(ours, ctrl, "fitness", ("our DE", "CMA-ES"))
    assert r["ci_method"].startswith("BCa bootstrap") and r["ci"][0] > 0 and r["verdict"] == "our DE better (shown)"
    methods = {m: {} for m in peers_check.NAMES} | {"ours": ours, "cmaes": ctrl}
    rows = {(row[0], row[1]): row for row in peers_check.comparison_rows(methods)}
    assert rows[("our DE vs CMA-ES", "legs 1 & 6")][2] == 12
    assert rows[("our DE vs CMA-ES", "legs 1 & 6")][7] == "our DE better (shown)"
    assert rows[("our DE vs CMA-ES", "legs 1 & 6")][10] == "not shown"  # forward: -1, 0, +1 around 0
    assert rows[("our DE vs scipy DE", "-")][3] == "no pairs yet"


def test_success_rates_carry_a_wilson_interval():
    assert peers_check.rate(4, 4) == "4/4 [51, 100 %]"
    assert peers_check.rate(0, 1) == "0/1 [0, 79 %]" and peers_check.rate(0, 0) == "-"


def test_render_only_reads_the_files_and_runs_nothing(tmp_path, monkeypatch):
    raw, out = tmp_path / "t2.json", tmp_path / "t2.md"
    rows = [_table2_row(lost, 0, 30, 60, 20.0, 10.0) for lost in experiments.SCENARIOS]
    raw.write_text(json.dumps(rows))
    monkeypatch.setattr(experiments, "run", lambda *a: pytest.fail("render-only simulated"))
    p = experiments.Table2Params(seeds=10, raw=raw, peers=tmp_path / "none.json", out=out, render_only=True)
    md = experiments._table2(p, lambda m: None)
    assert out.read_text() == experiments.table2_page(md) and json.loads(raw.read_text()) == rows
    assert f"<!-- generated: {experiments.TABLE2_SECTION} " in out.read_text()  # `gaitmend docs` re-renders it
    # the paper's before and after beside ours: quoted numbers, N/A where its robot fell
    assert "| fell (N/A) | -9.3 / 28.1 / -19.5 |" in md and "| -2.3 / 1.5 / 2.4 | 10.1 / 52.7 / 5.8 |" in md
    assert "| 14.6 / 26.6 / 64.0 | 9.4 / 66.9 / 13.0 |" in md
    assert "| our DE vs random search | all damages | 4 | +10.00" in md and "no pairs yet" in md


def test_render_only_without_rows_says_so(tmp_path):
    md = experiments.run_table2(10, 60, 30, raw_path=tmp_path / "none.json", peers_path=None, render_only=True)
    assert md.startswith("*No Table II runs of DE 30 x 60") and not (tmp_path / "none.json").exists()


def test_the_readme_line_states_the_pooled_verdicts_of_the_page():
    # six seeds of one damage: our DE 2-4 above random search on every seed (shown); no peers yet
    rows = [_table2_row((1,), s, 30, 60, fitness=10.0 + s % 3, rs_fitness=7.0 - s % 2) for s in range(6)]
    rows[0]["target_met"] = False
    line = peers_check.summary_line(rows, None, 30, 60, 0.001)
    assert line.startswith("- **recovery** (paper 000, Table II's 1 damage x seeds 0-5, DE 30 x 60 at 1 ms)")
    assert "target met in 5/6 runs (random search at the same budget: 0/6)" in line
    assert "against random search (6 pairs) our DE better (shown)" in line and "CMA-ES" not in line
    # what the rate stands on: the damages the nominal tripod already meets it with, and the robustness re-runs
    assert "the nominal tripod, no search, already meets it with none lost" in line
    assert "keep it at half the step in 6/6 and in a median 1 of the 1 robustness cases" in line
    rows[1]["baseline_target_met"] = True
    assert "already meets it with leg 1 lost" in peers_check.summary_line(rows, None, 30, 60, 0.001)
    assert peers_check.summary_line([], None, 30, 60, 0.001) == ""
    # the section reads the committed ledgers: its verdicts are the page's pooled rows
    text = experiments.render_summary([json.loads((ROOT / experiments.TABLE2_JSON).read_text()),
                                       json.loads((ROOT / peers_check.JSON).read_text())])
    page = (ROOT / "docs/table2.md").read_text()
    for other in ("random search", "scipy DE", "CMA-ES"):
        row = next(line for line in page.splitlines() if line.startswith(f"| our DE vs {other} | all damages |"))
        cells = [c.strip() for c in row.strip("|").split("|")]  # pairs in the 3rd column, the F verdict in the 8th
        assert f"against {other} ({cells[2]} pairs) {cells[7]}" in text, (text, row)

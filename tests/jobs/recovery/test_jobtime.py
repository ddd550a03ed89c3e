"""The job-time and F-scale figures of docs/recovery.md and README.md (issue 28) come from
Table II's rows: each figure below is the fixture rows' own, and a row that recorded no
load says so (no simulation here)."""

import json
from app.jobs.recovery.reproduce import experiments, jobtime

V = experiments.ROW_VERSION


def _row(lost, seed, wall, step=0.001, load=None, y=1.0, roll=1.0, pitch=0.5, fitness=20.0, gen=60):
    r = {"version": V, "lost_legs": list(lost), "seed": seed, "generations": gen, "population": 30,
         "timestep_s": step, "wall_s": wall, "best_fitness": fitness,
         "best": {"y_f_m": y, "roll_amp_deg": roll, "pitch_amp_deg": pitch}}
    return r | ({"load_before": load[0], "load_after": load[1], "cores": 2} if load else {})


ROWS = [_row((1, 6), 0, 600.0), _row((1, 6), 1, 300.0, load=(4.0, 6.5)), _row((1, 6), 2, 1200.0, load=(1.5, 2.0)),
        _row((3, 4), 0, 60.0, y=0.9, roll=2.5, fitness=12.0), _row((1,), 0, 240.0, y=0.5, roll=0.2, pitch=0.4,
                                                                       fitness=90.0),
        _row((1, 6), 0, 3000.0, step=0.002), _row((1, 6), 0, 5.0, gen=2),  # another step; another budget
        {"version": V - 1, "lost_legs": [1, 6], "seed": 3, "wall_s": 1.0}]  # an old format: dropped


def test_the_readme_line_is_the_default_jobs_runs_with_their_load():
    line = jobtime.render_readme_time([ROWS], V)
    assert "legs 1 & 6 row at 1 ms" in line and "3 runs (seeds 0-2)" in line
    assert "median of 10.0 min (5.0 to 20.0 min)" in line  # 600, 300, 1200 s
    assert "(2 cores)" in line and "load 1.5-6.5; load not recorded for 1" in line


def test_the_readme_line_leads_with_the_first_command_timed_as_written():
    """docs/readme_examples.json's latest run of the first command comes first, with its load;
    an example of another key is not read as it."""
    run = {"key": "first-command", "wall_s": 330.0, "machine": {"cores": 2}, "load_before": 0.2, "load_after": 1.9,
           "date": "2026-12-03 16:00 UTC"}
    older = run | {"wall_s": 900.0}
    other = run | {"key": '{"kind":"recovery"}', "wall_s": 60.0}
    line = jobtime.render_readme_time([ROWS, {"runs": [older, run, other]}], V)
    assert line.startswith("How long the first command takes: 5.5 min as the README writes it (2 cores, 1-minute "
                           "load 0.2 before and 1.9 after, 2026-12-03 16:00 UTC;")
    assert "The same job is Table II's legs 1 & 6 row at 1 ms" in line and "median of 10.0 min" in line
    assert jobtime.render_readme_time([ROWS, {"runs": [other]}], V) == jobtime.render_readme_time([ROWS], V)
    assert jobtime.render_readme_time([[], {"runs": [run]}], V).startswith(
        "How long the first command takes: 5.5 min as the README writes it")
    host = {"cpu": "AMD EPYC", "cpu_family": 26, "cpu_model": 2, "cores": 2}
    assert "5.5 min as the README writes it (AMD EPYC, family 26 model 2, 2 cores, 1-minute load 0.2" in \
        jobtime.render_readme_time([ROWS, {"runs": [run | {"machine": host}]}], V)


def test_the_readme_line_names_the_latest_run_on_each_other_recorded_host():
    """Hosts sold under one CPU name differ in speed: the latest run leads, then the latest
    run of every other host that recorded its CPU family and model (a run that did not is
    not told apart from the others' hosts, so it is left out)."""
    fast = {"cpu": "AMD EPYC", "cpu_family": 26, "cpu_model": 2, "cores": 2}
    slow = fast | {"cpu_family": 25, "cpu_model": 17}
    run = {"key": "first-command", "wall_s": 120.0, "machine": fast, "load_before": 1.0, "load_after": 2.0,
           "date": "2026-12-04 13:48 UTC"}
    slow_old, slow_new = run | {"machine": slow, "wall_s": 300.0}, run | {"machine": slow, "wall_s": 210.0,
                                                                         "date": "2026-12-04 15:40 UTC"}
    unnamed = run | {"machine": {"cpu": "AMD EPYC", "cores": 2}, "wall_s": 999.0}
    line = jobtime.render_readme_time([ROWS, {"runs": [unnamed, slow_old, slow_new, run | {"wall_s": 150.0}, run]}],
                                      V)
    assert line.startswith("How long the first command takes: 2.0 min as the README writes it (AMD EPYC, family 26 "
                           "model 2, 2 cores, 1-minute load 1.0 before and 2.0 after, 2026-12-04 13:48 UTC; "
                           "[docs/benchmarks.md](docs/benchmarks.md#whole-jobs)); 3.5 min on AMD EPYC, family 25 "
                           "model 17, 2 cores (load 1.0 before and 2.0 after, 2026-12-04 15:40 UTC). The same job")
    assert "16.6 min" not in line and "2.5 min" not in line and "5.0 min" not in line
    # several other hosts: newest run first, whichever host was seen first
    third = run | {"machine": fast | {"cpu_family": 23, "cpu_model": 49}, "wall_s": 240.0}
    line = jobtime.render_readme_time([ROWS, {"runs": [slow_old, third, slow_new, run]}], V)
    assert "); 3.5 min on AMD EPYC, family 25 model 17, 2 cores (load" in line
    assert line.index("3.5 min on AMD EPYC, family 25") < line.index("4.0 min on AMD EPYC, family 23 model 49")


def test_the_job_time_table_by_step_default_damage_and_all():
    table = jobtime.render_job_time([ROWS], V).splitlines()
    assert table[2] == ("| 1 ms | legs 1 & 6 (the default job) | 3 (seeds 0-2) | 600 | 300 / 1200 "
                        "| 1.5-6.5; not recorded for 1 |")
    assert table[3] == "| 1 ms | all 3 Table II damages | 5 (seeds 0-2) | 300 | 60 / 1200 | 1.5-6.5; not recorded for 3 |"
    assert table[4] == "| 2 ms | legs 1 & 6 (the default job) | 1 (seed 0) | 3000 | 3000 / 3000 | not recorded |"
    assert len(table) == 6  # the 2 ms rows of all damages; the other budget and the old format are not shown


def test_the_f_scale_groups_one_and_two_leg_losses():
    lines = jobtime.render_f_scale([ROWS], V).splitlines()
    assert lines[1] == ("- one leg lost (1 answer, leg 1): forward 50-50 cm, the larger of roll and pitch amplitude "
                        "0.4-0.4 deg, F 90.0-90.0.")
    assert lines[2] == ("- two legs lost (4 answers, legs 1 & 6, legs 3 & 4): forward 90-100 cm, the larger of roll "
                        "and pitch amplitude 1.0-2.5 deg, F 12.0-20.0.")


def test_no_rows_says_so():
    assert "No paper-budget row" in jobtime.render_job_time([None], V)
    assert "no run of it" in jobtime.render_readme_time([[]], V)
    assert jobtime.estimate([], V, 4, 1.0).startswith("no estimate")


def test_the_reproductions_estimate_is_from_the_rows_done():
    # 1 ms paper-budget rows: 600, 300, 1200, 60, 240 s -> fastest 60 s, median 300 s; 8 runs at half the cost
    text = jobtime.estimate(ROWS, V, 8, 0.5)
    assert text.startswith("estimate 4-20 min (the fastest and the median of the 5 runs done, load 1.5-6.5")


def test_each_run_kept_records_the_load_and_cores(monkeypatch, tmp_path):
    class Done:
        summary = {"x": 1}

    monkeypatch.setattr(experiments, "run", lambda spec, ctx: Done())
    rows: list[dict] = []
    experiments._run_and_keep(None, lambda s: {"seen": s["x"]}, rows, [], tmp_path / "t.json")
    saved = json.loads((tmp_path / "t.json").read_text())
    assert saved == rows and rows[0]["seen"] == 1
    assert {"load_before", "load_after", "cores"} <= set(rows[0]) and rows[0]["load_before"] >= 0

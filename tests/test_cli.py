"""`gaitmend run` as a user runs it: a subprocess, exit codes, files written."""

import json
import subprocess
import sys
import zipfile

import pytest

SMALL = {"kind": "recovery", "damage": {"lost_legs": [3, 4]},
         "search": {"population": 6, "generations": 2, "seed": 11}, "sim": {"duration_s": 2.0}}


def gaitmend(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "app", *args], capture_output=True, text=True, cwd=cwd, timeout=600)


def test_run_writes_a_bundle_and_json_summary_and_the_manifest_reproduces_it(tmp_path):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(SMALL))
    out = tmp_path / "out"
    p = gaitmend("run", str(spec), "--out", str(out), "--json")
    assert p.returncode == 0, p.stderr
    summary = json.loads(p.stdout.strip().splitlines()[-1])
    assert {"baseline", "best", "gait", "history", "timing"} <= set(summary)
    assert set(summary["timing"]) >= {"wall_s", "evaluations", "sim_steps_per_s"}
    assert "best F" in p.stderr and "evals" in p.stderr  # the progress bar went to stderr

    bundle = out / f"{summary['job_id']}.zip"
    with zipfile.ZipFile(bundle) as z:
        names = set(z.namelist())
        manifest = json.loads(z.read("manifest.json"))
    for f in ("manifest.json", "result.json", "history.csv", "robot.xml", "README.md",
              "trajectories/best.npz", "trajectories/best.csv", "trajectories/baseline.npz",
              "plots/convergence.svg", "plots/convergence.png", "plots/orientation.svg", "plots/com.svg",
              "plots/gait_diagram_best.svg"):
        assert f in names
    assert manifest["spec"]["search"]["seed"] == 11 and manifest["seed"] == 11
    assert set(manifest["versions"]) >= {"gaitmend", "mujoco", "numpy", "python"}
    assert manifest["evaluations"] == summary["timing"]["evaluations"]

    folder = out / summary["job_id"]  # unpacked beside the zip, in a folder of its own
    assert json.loads((folder / "manifest.json").read_text()) == manifest
    again = gaitmend("run", str(folder / "manifest.json"), "--out", str(out), "--json", "--quiet")
    assert again.returncode == 0, again.stderr
    rerun = json.loads(again.stdout.strip().splitlines()[-1])
    for key in ("baseline", "best", "gait", "history"):
        assert rerun[key] == summary[key]
    assert rerun["job_id"] != summary["job_id"]  # the same --out: a second folder, the first one untouched
    assert json.loads((folder / "manifest.json").read_text()) == manifest
    assert json.loads((out / rerun["job_id"] / "manifest.json").read_text())["model_sha256"] == manifest["model_sha256"]
    readme = (folder / "README.md").read_text()
    assert "gaitmend verify manifest.json" in readme and "pip install \"gaitmend==" not in readme

    same = gaitmend("verify", str(folder), "--quiet", "--json")  # re-runs and compares every number
    assert same.returncode == 0 and same.stdout.startswith("identical: same numbers"), same.stdout + same.stderr
    checked = json.loads(same.stdout.strip().splitlines()[-1])
    assert checked["outcome"] == "identical" and checked["numbers"] > 100 and checked["made_on"] == checked["machine"]
    result = json.loads((folder / "result.json").read_text())
    fitness = result["best"]["fitness"]
    result["best"]["fitness"] = fitness * (1 + 1e-12)  # floating-point order: equal within the stated tolerance
    (folder / "result.json").write_text(json.dumps(result))
    near = gaitmend("verify", str(folder), "--quiet", "--json")
    assert near.returncode == 0 and near.stdout.startswith("equal within tolerance: 1 of"), near.stdout + near.stderr
    assert json.loads(near.stdout.strip().splitlines()[-1])["where"] == "best.fitness"
    assert gaitmend("verify", str(folder), "--quiet", "--exact").returncode == 1  # not bit for bit
    result["best"]["fitness"] = fitness + 1e-6
    (folder / "result.json").write_text(json.dumps(result))
    differ = gaitmend("verify", str(folder / "manifest.json"), "--quiet")
    assert differ.returncode == 1 and "DIFFERENT: best.fitness" in differ.stdout, differ.stdout + differ.stderr
    assert "1 of " in differ.stdout and "made on " in differ.stdout and "verified on " in differ.stdout


def test_verify_compares_a_bundle_null_with_a_fresh_nan():
    """A bundle writes a number that is not finite as null (JSON has none), a fresh run holds
    the float: the same number to `gaitmend verify`; NaN is the same as NaN."""
    from app.cli.local import first_difference

    nan, inf = float("nan"), float("inf")
    fresh = {"best": {"fitness": 1.5, "sm_m": nan, "tip_s": inf, "low": -inf}, "history": [[0, nan], [1, 2.0]]}
    bundle = {"best": {"fitness": 1.5, "sm_m": None, "tip_s": None, "low": None}, "history": [[0, None], [1, 2.0]]}
    assert first_difference(bundle, fresh) is None
    assert first_difference(fresh, fresh) is None  # NaN == NaN (a bundle written before nulls)
    assert first_difference({"a": None}, {"a": None}) is None
    assert first_difference(bundle | {"best": bundle["best"] | {"fitness": None}}, fresh) == \
        "best.fitness: bundle None, new run 1.5"  # null stands only for a number that is not finite
    assert first_difference({"h": [nan]}, {"h": [1.0]}) == "h.0: bundle nan, new run 1.0"
    assert first_difference({"h": [nan]}, {"h": [inf]}) == "h.0: bundle nan, new run inf"
    assert first_difference({"h": [None]}, {"h": [0]}) == "h.0: bundle None, new run 0"


@pytest.mark.parametrize("patch,needle", [
    ({"robot": "atlas"}, "robot: unknown robot 'atlas'"),
    ({"damage": {"lost_legs": [2, 4]}}, "damage.lost_legs: infeasible morphology"),
    ({"bounds": {"step_length_m": [0.05, 0.02]}}, "step_length_m: lower bound 0.05 exceeds upper bound 0.02"),
    ({"search": {"population": 2}},
     "search.population: Input should be greater than or equal to 4; allowed: 4 <= population <= 1000"),
    ({"sim": {"duration_s": -1}},
     "sim.duration_s: Input should be greater than or equal to 0.5; allowed: 0.5 <= duration_s <= 120 (in s)"),
    ({"damage": {"lost_legs": [7]}}, "damage.lost_legs.0: Input should be less than or equal to 6; "
                                     "allowed: 1 <= lost_legs[0] <= 6"),
    ({"gravity": 3}, "gravity: unknown field"),
])
def test_bad_specs_exit_2_name_the_field_and_write_nothing(tmp_path, patch, needle):
    spec = tmp_path / "bad.json"
    spec.write_text(json.dumps(SMALL | patch))
    out = tmp_path / "out"
    p = gaitmend("run", str(spec), "--out", str(out))
    assert p.returncode == 2
    assert needle in " ".join(p.stderr.split())
    assert not out.exists()


def test_unreadable_spec_exits_2(tmp_path):
    (tmp_path / "x.json").write_text("{not json")
    assert gaitmend("run", str(tmp_path / "x.json"), "--out", str(tmp_path / "o")).returncode == 2
    assert gaitmend("run", str(tmp_path / "missing.json"), "--out", str(tmp_path / "o")).returncode == 2


def test_multigait_run_prints_its_coverage_table(tmp_path):
    spec = tmp_path / "mg.json"
    spec.write_text(json.dumps({"kind": "multigait", "robot": "lizard", "damage": {"stuck_modules": [3]},
                                "search": {"particles": 4, "generations": 2}, "planner": {"iterations": 20},
                                "reuse": {"plans": 2, "iterations": 10}, "verify": {"nodes": 5},
                                "gait_duration_s": 5.0}))
    p = gaitmend("run", str(spec), "--out", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    text = " ".join(p.stdout.split())  # rich wraps the title at the terminal width
    assert "lizard: 3 gaits, cost coverage" in text and "stuck modules [3]" in text
    assert "first generation" in text and "final best" in text
    assert "re-planned cost matches the search: True" in text
    assert "reuse column_opposite: distance" in text


def test_summary_tables_through_a_narrow_pipe_cut_nothing(tmp_path):
    """`gaitmend run | cat` with COLUMNS=60: a pipe has no width to fit, so no cell, header or
    number is cut to "…" (issue 16: `no_re…`, `thresh…` in logs)."""
    import os

    from app.jobs.registry import KINDS

    kind = KINDS["recovery"]  # the widest tables: Table II, the controls and the robustness cases
    spec = tmp_path / "smoke.json"
    spec.write_text(json.dumps(kind.smoke_spec()))
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "app", "run", str(spec), "--out", str(out), "--quiet"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=600,
                       env=os.environ | {"COLUMNS": "60", "LINES": "20"})
    assert p.returncode == 0, p.stderr
    assert "…" not in p.stdout and "..." not in p.stdout, p.stdout
    (folder,) = [d for d in out.iterdir() if d.is_dir()]
    tables = kind.summary_tables(json.loads((folder / "result.json").read_text()))
    assert tables and sum(len(t["rows"]) for t in tables) >= 3
    for t in tables:
        for name in [t["title"], *map(str, t["columns"])]:
            assert name in p.stdout, f"{name!r} is not whole in:\n{p.stdout}"
        for row in t["rows"]:
            for v in row:
                assert ("-" if v is None else str(v)) in p.stdout, f"cell {v!r} is not whole in:\n{p.stdout}"


def test_version_and_replay_of_a_missing_path(tmp_path):
    from app import __version__

    v = gaitmend("--version")
    assert v.returncode == 0 and v.stdout.strip() == f"gaitmend {__version__}"
    r = gaitmend("replay", str(tmp_path / "nonexistent"))
    assert r.returncode == 2 and "no such bundle file or folder" in r.stderr and "Connection" not in r.stderr


def test_reproduce_writes_beside_docs_unless_asked(tmp_path):
    r = gaitmend("reproduce", "recovery-baselines", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "reproduced" / "recovery_baselines.md").is_file() and not (tmp_path / "docs").exists()
    assert "--write-docs" in r.stderr


@pytest.mark.parametrize("text, needle", [
    ('{"kind": "recovery", "kind": "tipping"}', "kind: duplicate key"),
    ('{"kind": "recovery", "sim": {"duration_s": NaN}}', "sim.duration_s: NaN is not JSON"),
])
def test_spec_files_get_the_api_parser(tmp_path, text, needle):
    spec = tmp_path / "bad.json"
    spec.write_text(text)
    p = gaitmend("run", str(spec), "--out", str(tmp_path / "out"))
    assert p.returncode == 2 and needle in " ".join(p.stderr.split()), p.stderr
    assert not (tmp_path / "out").exists()


def test_run_prints_the_verdict_with_the_held_out_figure_and_the_bundle_readme_says_it_too(tmp_path):
    """Issue 46: `gaitmend run`'s summary ends with the verdict, whose first words call a
    gait fragile when its held-out random models do not keep the target; the bundle's README
    and the --json summary state the same figure."""
    from verdict_support import FRAGILE

    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(FRAGILE))
    p = gaitmend("run", str(spec), "--out", str(tmp_path / "out"), "--quiet")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.strip().splitlines()
    verdict = next(line for line in lines if line.startswith("Verdict: "))
    assert verdict.startswith("Verdict: Fragile: keeps the target on 0 of 20: do not take it to the robot as it is."), verdict
    assert "0 of 20 held-out random models keep the target (95 % interval 0–16 %)" in verdict
    assert "named cases" in verdict and "timestep checks" in verdict
    assert any("fewer than 80 % of the held-out random models keep the target" in line for line in lines)
    folder = next(d for d in (tmp_path / "out").iterdir() if d.is_dir())
    readme = (folder / "README.md").read_text()
    assert "## Verdict" in readme and verdict in readme
    assert "more than 5 % of them fall" in readme

    j = gaitmend("run", str(folder / "manifest.json"), "--out", str(tmp_path / "again"), "--json", "--quiet")
    held = json.loads(j.stdout.strip().splitlines()[-1])["verdict"]["held_out"]
    assert (held["met"], held["n"], held["fragile"]) == (0, 20, True)
    assert held["text"].startswith("0 of 20 held-out random models keep the target")

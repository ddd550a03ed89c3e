"""`gaitmend reproduce readme-examples` and the sections it feeds (issue 28): the README's
example lines are read from the README itself (one per kind; a README of another shape is
refused, saying what is missing), each measured run is appended with its load, machine,
commit and date, an example already in the file is skipped unless asked, and the README's
sentence and docs/benchmarks.md's whole-jobs table render from the file. No simulation
runs here: the command runner is a fake."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.cli.examples import (FIRST_KEY, ExamplesParams, ReadmeShapeError, key_of, parse_examples, parse_first,
                               reproduce_examples)
from app.jobs.registry import KINDS
from app.results import docs_gen, examples

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _run(spec: str, wall: float, load=(4.25, 5.5), commit="0123456789abcdef", date="2026-12-03 15:00 UTC") -> dict:
    return {"kind": json.loads(spec)["kind"], "spec": spec, "key": key_of(json.loads(spec)),
            "command": f"echo '{spec}' | gaitmend run /dev/stdin --out results/",
            "machine": {"cpu": "Test CPU", "cores": 2, "python": "3.11"}, "load_before": load[0],
            "load_after": load[1], "nice": 10, "commit": commit, "date": date, "wall_s": wall, "cpu_s": wall * 0.9}


FIXTURE = {"schema": 1, "experiment": "readme-examples", "command": examples.COMMAND, "runs": [
    _run('{"kind": "tipping"}', 300.0, load=(9.0, 9.5), date="2026-12-01 10:00 UTC"),
    _run('{"kind": "tipping"}', 93.4),
    _run('{"kind": "energy", "search": {"population": 8, "generations": 3}}', 150.0, load=(3.0, 6.75),
         commit="fedcba9876543210+dirty"),
]}


def test_the_readme_examples_are_read_from_the_readme_one_per_kind():
    found = parse_examples(README)
    assert sorted(e["kind"] for e in found) == sorted(KINDS)
    for e in found:
        assert e["command"] in README  # the very line the README shows
        assert json.loads(e["spec"])["kind"] == e["kind"] and e["key"] == key_of(json.loads(e["spec"]))


def test_a_readme_of_another_shape_is_refused_clearly():
    with pytest.raises(ReadmeShapeError, match="no '## One job per kind' section"):
        parse_examples(README.replace("## One job per kind", "## Kinds"))
    tipping = "echo '{\"kind\": \"tipping\"}' | gaitmend run /dev/stdin --out results/"
    assert tipping in README
    with pytest.raises(ReadmeShapeError, match=r"one example line per kind .*wrong: tipping"):
        parse_examples(README.replace(tipping, ""))
    with pytest.raises(ReadmeShapeError, match="not of the form"):
        parse_examples(README.replace(tipping, tipping.replace("/dev/stdin", "tipping.json")))
    with pytest.raises(ReadmeShapeError, match="not JSON"):
        parse_examples(README.replace(tipping, tipping.replace('"tipping"}', '"tipping",}')))
    with pytest.raises(ReadmeShapeError, match="found none"):
        parse_examples("# x\n\n## One job per kind\n\nno examples\n\n## Next\n")


def test_the_first_commands_job_is_read_from_the_readme():
    """The first command's job is the `gaitmend run --out results/` that ends the README's
    install line (the install is not timed); a README without it is refused."""
    first = parse_first(README)
    assert first["command"] == "gaitmend run --out results/" and first["key"] == FIRST_KEY and first["spec"] == "{}"
    line = next(ln for ln in README.splitlines() if ln.endswith(first["command"]) and not ln.startswith("#"))
    assert "pip install" in line  # the install line, as the README shows it
    with pytest.raises(ReadmeShapeError, match="first command"):
        parse_first(README.replace("gaitmend run --out results/\n```", "gaitmend run\n```"))
    with pytest.raises(ReadmeShapeError, match="no '## Two commands' section"):
        parse_first(README.replace("## Two commands", "## Start"))


def test_the_first_command_is_in_the_table_and_not_in_the_examples_sentence():
    run = _run('{"kind": "recovery"}', 400.0) | {"key": FIRST_KEY, "spec": "{}", "command": "gaitmend run --out results/"}
    data = {**FIXTURE, "runs": [*FIXTURE["runs"], run]}
    assert "| recovery (the first command) | `gaitmend run --out results/` | 400 s |" in examples.render_table(data)
    assert examples.render_sentence(data) == examples.render_sentence(FIXTURE)


def test_the_table_shows_each_example_latest_run_with_its_load():
    text = examples.render_table(FIXTURE)
    assert "| tipping | `{\"kind\": \"tipping\"}` | 93 s | 84 s | 4.2 / 5.5 | 2026-12-03 15:00 UTC | 0123456789 |" in text
    assert "300 s" not in text  # the earlier tipping run stays in the file, not shown
    assert "| 150 s | 135 s | 3.0 / 6.8 |" in text and "fedcba9876 (uncommitted changes)" in text
    assert "Test CPU, 2 cores, nice 10" in text
    assert "No data yet" in examples.render_table(None) and "No data yet" in examples.render_sentence({"runs": []})


def test_the_readme_sentence_states_the_range_and_the_load():
    assert examples.render_sentence(FIXTURE) == (
        "Each took 93 s to 150 s (tipping 93 s, energy 150 s) on 2 shared cores at a 1-minute load of 3.0-6.8 "
        "([docs/benchmarks.md](docs/benchmarks.md#whole-jobs)).\n")


def test_reproduce_appends_each_example_and_skips_those_already_there(tmp_path):
    readme, path = tmp_path / "README.md", tmp_path / "readme_examples.json"
    readme.write_text(README)
    lines = [e["command"] for e in parse_examples(README)]
    first = parse_first(README)["command"]
    calls: list[str] = []

    def fake(command, log):
        calls.append(command)

    path.write_text(json.dumps({**FIXTURE, "runs": [FIXTURE["runs"][1]]}))  # tipping's, measured already
    reproduce_examples(ExamplesParams(readme=readme, json_out=path), lambda m: None, fake)
    assert calls == [first] + [c for c in lines if '"tipping"' not in c]  # in the README's order, one at a time
    runs = json.loads(path.read_text())["runs"]
    assert len(runs) == len(KINDS) + 1 and runs[-1]["command"] == lines[-1]
    assert {"machine", "load_before", "load_after", "commit", "date", "nice", "wall_s", "cpu_s", "spec"} <= runs[-1].keys()
    reproduce_examples(ExamplesParams(readme=readme, json_out=path), lambda m: None, fake)
    assert len(calls) == len(KINDS)  # nothing left to measure
    reproduce_examples(ExamplesParams(kinds="tipping", readme=readme, json_out=path), lambda m: None, fake)
    tipping = next(c for c in lines if '"tipping"' in c)
    assert calls[-1] == tipping and len(json.loads(path.read_text())["runs"]) == len(KINDS) + 2
    reproduce_examples(ExamplesParams(kinds="first", readme=readme, json_out=path), lambda m: None, fake)
    assert calls[-1] == first and len(json.loads(path.read_text())["runs"]) == len(KINDS) + 3
    readme.write_text(README.replace("## One job per kind", "## Kinds"))
    with pytest.raises(ReadmeShapeError):
        reproduce_examples(ExamplesParams(readme=readme, json_out=path), lambda m: None, fake)
    with pytest.raises(ValueError, match="no kind named nope"):
        ExamplesParams(kinds="tipping,nope")


def test_the_pages_follow_the_committed_file(docs_copy):
    tmp_path = docs_copy
    assert docs_gen.check(tmp_path) == []
    path = tmp_path / examples.JSON
    data = json.loads(path.read_text())
    assert {e["key"] for e in parse_examples(README)} <= {r["key"] for r in data["runs"]}  # every example measured
    data["runs"].append(data["runs"][0] | {"wall_s": 4321.0})
    path.write_text(json.dumps(data))
    diffs = docs_gen.check(tmp_path)
    assert sorted(d.split("\n")[0] for d in diffs) == ["--- README.md (as written)", "--- docs/benchmarks.md (as written)"]
    assert all("72.0 min" in d for d in diffs)

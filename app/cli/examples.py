"""`gaitmend reproduce readme-examples`: how long the README's example lines take (issue 28).

The examples are read from README.md itself, the fenced `echo '<spec>' | gaitmend run
/dev/stdin --out results/` lines of its "## One job per kind" section, one per kind, so the
commands measured are exactly the ones the README shows; a README whose section or lines
no longer have that shape is refused with what is missing. Each line runs, as written, in a
bash that a user would type it into (``gaitmend`` being this checkout's CLI, ``python -m
app``) in an empty folder, one example at a time, and is appended to
docs/readme_examples.json with the wall and CPU seconds of the whole command, the 1-minute
load average before and after, the machine, the niceness, the commit and the date; an
example whose spec is there already is skipped unless --kinds names its kind.
app/results/examples.py renders the file.

It lives here, beside `gaitmend reproduce bench`, because it spans every kind and runs the CLI."""

from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, field_validator

from app.cli.bench import _names, append_measured, measured
from app.cli.common import default_spec_data
from app.jobs.base import Experiment
from app.jobs.ledger import ROOT
from app.jobs.registry import KINDS
from app.results import examples as rendered

SECTION = "## One job per kind"
FIRST_SECTION = "## Two commands"
FIRST_KEY = "first-command"  # the README's first command: the default recovery job, no spec
FIRST_RUN = re.compile(r"(?P<run>gaitmend run --out results/)$")
FENCE = re.compile(r"^```bash\n(?P<body>.*?)^```", re.M | re.S)
LINE = re.compile(r"^echo '(?P<spec>\{.*\})' \| gaitmend run /dev/stdin --out results/$")


class ReadmeShapeError(ValueError):
    """README.md no longer holds the example lines in the shape this reproduction reads."""


def key_of(spec: dict) -> str:
    """The spec as canonical JSON: an example's identity, whatever the commit or its spacing."""
    return json.dumps(spec, sort_keys=True, separators=(",", ":"))


def _section(text: str, title: str = SECTION) -> str:
    start = text.find(f"\n{title}\n")
    if start < 0:
        raise ReadmeShapeError(f"README.md has no {title!r} section: the example lines are read from it")
    end = text.find("\n## ", start + len(title) + 2)
    return text[start:end if end >= 0 else len(text)]


def parse_first(text: str) -> dict:
    """The README's first command's job (the ``gaitmend run --out results/`` that ends the
    first fenced line of "## Two commands", after the install), as an example: the default
    spec, keyed ``first-command``; the install before it is not timed."""
    for block in FENCE.finditer(_section(text, FIRST_SECTION)):
        for line in block["body"].splitlines():
            m = FIRST_RUN.search(line.strip())
            if m and not line.lstrip().startswith("#"):
                return {"kind": default_spec_data()["kind"], "spec": "{}", "key": FIRST_KEY, "command": m["run"],
                        "first": True}
    raise ReadmeShapeError(f"{FIRST_SECTION} has no fenced line ending in `gaitmend run --out results/` (the first "
                           "command, whose job is timed)")


def parse_examples(text: str, kinds: Iterable[str] = KINDS) -> list[dict]:
    """The example lines of a README's "## One job per kind" section, in order: {kind, spec
    (the README's JSON text), key, command (the line as written)}; exactly one per kind."""
    found, odd = [], []
    for block in FENCE.finditer(_section(text)):
        for line in filter(str.strip, block["body"].splitlines()):
            m = LINE.match(line.strip())
            if m is None:
                odd.append(line)
                continue
            try:
                spec = json.loads(m["spec"])
            except json.JSONDecodeError as e:
                raise ReadmeShapeError(f"an example line's spec is not JSON ({e}): {line}") from None
            found.append({"kind": spec.get("kind"), "spec": m["spec"], "key": key_of(spec), "command": line.strip()})
    if odd:
        raise ReadmeShapeError(f"{SECTION} has fenced bash lines not of the form "
                               f"\"echo '<spec>' | gaitmend run /dev/stdin --out results/\": {odd}")
    named = [e["kind"] for e in found]
    wrong = [k for k in kinds if named.count(k) != 1] + [k for k in named if k not in kinds]
    if wrong:
        raise ReadmeShapeError(f"{SECTION} should hold one example line per kind ({', '.join(kinds)}); found "
                               f"{', '.join(map(str, named)) or 'none'} (wrong: {', '.join(map(str, wrong))})")
    return found


def run_line(command: str, log: Callable[[str], None]) -> None:
    """The README's line, as written, in bash in an empty folder, with `gaitmend` this checkout's CLI."""
    env = os.environ | {"PYTHONPATH": str(ROOT), "GAITMEND_PY": sys.executable}
    script = f'gaitmend() {{ "$GAITMEND_PY" -m app "$@"; }}\nset -o pipefail\n{command}\n'
    with tempfile.TemporaryDirectory(prefix="gaitmend-example-") as tmp:
        done = subprocess.run(["bash", "-c", script], cwd=tmp, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"`{command}` exited {done.returncode}:\n{done.stderr[-2000:]}")
    log(done.stdout.strip().splitlines()[-1] if done.stdout.strip() else "(no output)")


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def measure_example(example: dict, log: Callable[[str], None],
                    run: Callable[[str, Callable[[str], None]], None] = run_line) -> dict:
    """One example with where and when: the commit as it starts, the date as it ends; CPU
    seconds are the command's own (every process it waited for)."""
    c0 = _children_cpu()

    def work() -> dict:
        run(example["command"], log)
        return dict(example)

    return measured(work) | {"cpu_s": round(_children_cpu() - c0, 1)}


class ExampleKinds(BaseModel):
    """A ``kinds`` option naming README examples by kind ('first': the first command's job),
    checked against the registry; a reproduction over the examples subclasses it."""

    model_config = ConfigDict(extra="forbid")

    kinds: str = Field("", description="kinds whose README example to measure again, comma-separated ('first': the "
                                       "first command's job; a new run is appended beside the old); empty: every "
                                       "example the file does not hold yet")

    @field_validator("kinds")
    @classmethod
    def _known(cls, v: str) -> str:
        unknown = [k for k in _names(v) if k not in KINDS and k != "first"]
        if unknown:
            raise ValueError(f"no kind named {', '.join(unknown)} (kinds: {', '.join(KINDS)}, or first)")
        return v


class ExamplesParams(ExampleKinds):
    readme: Path = Field(Path("README.md"), description="the README whose example lines are measured (relative: "
                                                        "to the repository)")
    json_out: Path = Field(Path(rendered.JSON), description="the file each example's run is appended to")


def reproduce_examples(p: ExamplesParams, log: Callable[[str], None] = print,
                       run: Callable[[str, Callable[[str], None]], None] = run_line) -> str:
    """Each README example not yet in the file (or of a kind asked for), one at a time, appended as it ends."""
    text = (ROOT / p.readme).read_text()
    examples = [parse_first(text), *parse_examples(text)]
    have = {r["key"] for r in json.loads(p.json_out.read_text())["runs"]} if p.json_out.exists() else set()
    again = _names(p.kinds)
    todo = [e for e in examples if ("first" if e.get("first") else e["kind"]) in again or e["key"] not in have]
    data = append_measured(p.json_out, "readme-examples", rendered.COMMAND, todo, lambda e: measure_example(e, log, run),
                           lambda e: f"{e['kind']}: {e['command']}", log)
    if not todo:
        log(f"every README example is in {p.json_out} already (--kinds K re-measures one)")
    return rendered.render_table(data)


EXPERIMENT = Experiment("readme-examples",
                        "README.md's example lines (one per kind, read from the README), each run as written "
                        "through the CLI one at a time and appended with its wall and CPU seconds, the load before "
                        "and after, the machine, the commit and the date (examples already in --json-out are "
                        "skipped unless --kinds names their kind)",
                        ExamplesParams, reproduce_examples, rendered.sections())

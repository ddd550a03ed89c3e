"""Local commands of `gaitmend`: run a job here (no server), benchmark, reproduce a paper."""

from __future__ import annotations

import contextlib
import hashlib
import inspect
import json
import time
import zipfile
from pathlib import Path
from typing import Any, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from app.cli.common import cli, err, fail, load_spec, out_console, print_tables
from app.jobs.base import MemoryContext, SpecError, dumps
from app.jobs.registry import KINDS, get_kind
# verify's comparison lives beside the bundle reader: the Python client's Bundle.verify makes it too
from app.results.verify import first_difference


class LocalContext(MemoryContext):
    """Run context for `gaitmend run`: a progress bar (the kind words its line),
    checkpoints kept in memory."""

    def __init__(self, artifact_dir: Path, progress: Progress | None, task=None, kind=None):
        from app.cli.robot import load_local_robot

        super().__init__(artifact_dir, robots=load_local_robot)  # robots uploaded with `gaitmend robot add`
        self._progress, self._task, self._kind = progress, task, kind

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        if self._progress is not None:
            text = self._kind.progress_text(info) if self._kind is not None else ""
            self._progress.update(self._task, completed=done, total=total, info=text)


def local_job_id(spec) -> str:
    h = hashlib.sha256(spec.model_dump_json().encode()).hexdigest()[:8]
    return f"local-{time.strftime('%Y%m%d-%H%M%S')}-{h}"


@cli.command()
def run(
    spec_path: Optional[Path] = typer.Argument(None, metavar="[SPEC]",
                                               help="spec JSON, a bundle's manifest.json or bundle zip; default: the embedded paper scenario (legs 1 and 6 lost)"),
    out: Path = typer.Option(Path("results"), "--out",
                             help="folder for results: the bundle goes to OUT/<job-id>.zip and is unpacked into "
                                  "OUT/<job-id>/ (never over another run)"),
    as_json: bool = typer.Option(False, "--json", help="print the summary as one JSON object on the last stdout line"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Run one job locally, with no server, and write its result bundle."""
    from app.jobs.verdict import brief, verdict_lines
    from app.results.bundle import write_bundle

    spec = load_spec(spec_path)
    kind = get_kind(spec.kind)
    job_id = local_job_id(spec)
    progress = None if quiet else Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"), TimeElapsedColumn(), console=err, transient=False)
    with (progress or contextlib.nullcontext()):
        task = progress.add_task(spec.kind, total=None, info="") if progress else None
        try:
            result = kind.run(spec, LocalContext(out, progress, task, kind))
        except SpecError as e:  # found only when the job starts: an uploaded robot not stored here, say
            fail(str(e))
    bundle = write_bundle(out / f"{job_id}.zip", job_id, spec, result)
    folder = out / job_id
    with zipfile.ZipFile(bundle) as z:
        z.extractall(folder)
    s = result.summary
    v = kind.verdict(json.loads(dumps(s)))
    if as_json:
        print(dumps(s | {"job_id": job_id, "bundle": str(bundle), "folder": str(folder), "verdict": brief(v)}))
        return
    con = out_console()
    print_tables(kind.summary_tables(s), con)
    for line in verdict_lines(v):  # the verdict last, where the eye lands: a fragile gait says so first
        con.print(line, highlight=False)
    tm = s["timing"]
    parts = [f"{tm['wall_s']:.1f} s"]
    if "evaluations" in tm:
        parts.insert(0, f"{tm['evaluations']} evaluations in")
    if tm.get("sim_steps_per_s"):
        parts.append(f"({tm['sim_steps_per_s'] / 1e3:.1f}k sim steps/s)")
    con.print(" ".join(parts) + f"; bundle: {bundle}, unpacked in {folder}/")


# -- gaitmend verify BUNDLE ----------------------------------------------------------------------

def _bundle_files(path: Path) -> tuple[dict, dict]:
    """(manifest, result) of a bundle zip, an unpacked bundle folder, or its manifest.json."""
    if path.suffix == ".zip":
        with zipfile.ZipFile(path) as z:
            return json.loads(z.read("manifest.json")), json.loads(z.read("result.json"))
    folder = path if path.is_dir() else path.parent
    return json.loads((folder / "manifest.json").read_text()), json.loads((folder / "result.json").read_text())


@cli.command()
def verify(bundle: Path = typer.Argument(..., help="a result bundle: .zip, unpacked folder, or its manifest.json"),
           quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
           exact: bool = typer.Option(False, "--exact", help="only bit-identical passes (exit 1 when within "
                                                              "tolerance)"),
           as_json: bool = typer.Option(False, "--json", help="the comparison as one JSON object on the last stdout "
                                                               "line")):
    """Re-run a bundle's job here and compare every number of its result with the bundle's
    (wall-clock times excepted): identical, equal within a stated tolerance (floating-point
    order: exit 0, 1 with --exact), or different (exit 1), with the figures and the machines."""
    from app.core.host import machine, machine_text
    from app.results.bundle import versions
    from app.results.verify import compare

    try:
        man, saved = _bundle_files(bundle)
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as e:
        fail(f"cannot read bundle {bundle}: {e}")
    spec = load_spec(bundle / "manifest.json" if bundle.is_dir() else bundle)
    kind = get_kind(spec.kind)
    progress = None if quiet else Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"), TimeElapsedColumn(), console=err, transient=False)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp, (progress or contextlib.nullcontext()):
        task = progress.add_task(f"verify {man.get('job_id', '')}", total=None, info="") if progress else None
        result = kind.run(spec, LocalContext(Path(tmp), progress, task, kind))
    c = compare(saved, json.loads(dumps(result.summary)))
    here, made = machine(), man.get("machine")
    print(c.text())
    print(f"made on {machine_text(made) if made else 'a machine the bundle does not name (an older bundle)'} "
          f"with {_versions_text(man.get('versions', {}))}; verified on {machine_text(here)} with "
          f"{_versions_text(versions())}")
    if as_json:
        print(json.dumps(c.to_json() | {"made_on": made, "machine": here, "versions_made": man.get("versions"),
                                        "versions": dict(versions())}))
    if c.outcome == "different" or (exact and c.outcome != "identical"):
        raise typer.Exit(1)


def _versions_text(v: dict) -> str:
    return ", ".join(f"{k} {v[k]}" for k in ("mujoco", "numpy", "python") if k in v) or "unrecorded versions"


@cli.command()
def bench(
    as_json: bool = typer.Option(False, "--json", help="print the figures as one JSON object on the last stdout line"),
    quick: bool = typer.Option(False, "--quick", help="small budget (CI smoke); figures are not the targets'"),
    kind: Optional[list[str]] = typer.Option(None, "--kind", help="only these kinds (repeat); default all"),
    studies: bool = typer.Option(False, "--studies", help="instead: a study's dispatch overhead per point through "
                                 "a real worker on the configured broker and database (200 tiny points; --quick 6)"),
    adapt: bool = typer.Option(False, "--adapt", help="instead: an adaptation session's proposal after 20 trials "
                               "with a 10,000-elite map, through the API (app/cli/adapt_bench.py; --quick: 1,000, 5)"),
):
    """Measure every kind's hot paths (rollout and evaluator throughput, paper-size runs, peers)."""
    from app.cli.bench import run_bench

    for k in kind or []:
        get_kind_or_exit(k)
    if adapt:
        from app.cli.adapt_bench import adapt_bench

        figures = adapt_bench(quick, log=err.print)
    elif studies:
        from app.cli.study_bench import POINTS, QUICK_POINTS, study_bench

        figures = study_bench(QUICK_POINTS if quick else POINTS, log=err.print)
    else:
        figures = run_bench(quick=quick, log=err.print, kinds=kind or None)
    if as_json:
        print(json.dumps(figures))
    else:
        for k, v in figures.items():
            Console().print(f"{k:28s} {v}")


def get_kind_or_exit(name: str):
    from app.cli.common import fail
    from app.jobs.base import SpecError

    try:
        return get_kind(name)
    except SpecError as e:
        fail(str(e))


# -- gaitmend reproduce <kind> ----------------------------------------------------------------

reproduce_app = typer.Typer(no_args_is_help=True, help="Reproduce a paper's experiments: one command per kind.")
cli.add_typer(reproduce_app, name="reproduce")


DOCS = Path("docs")
REPRODUCED = Path("reproduced")


def _experiment_command(experiment):
    """A Typer command whose options are the experiment's ``Params`` fields, plus
    --write-docs: by default a file the experiment would write under docs/ goes to
    reproduced/ instead, so reproducing never overwrites the published results it is to be
    compared with (and never reuses their cached rows)."""
    fields = experiment.Params.model_fields
    params, annotations = [], {}
    for name, f in fields.items():
        ann = f.annotation
        flag = "--" + name.replace("_", "-")
        opt = typer.Option(f.default, flag, help=f.description or "")
        params.append(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=opt, annotation=ann))
        annotations[name] = ann
    params.append(inspect.Parameter("write_docs", inspect.Parameter.KEYWORD_ONLY, annotation=bool,
                                    default=typer.Option(False, "--write-docs",
                                                         help="write into docs/ (default: reproduced/)")))
    annotations["write_docs"] = bool

    def command(**kw):
        from pydantic import ValidationError

        from app.cli.common import fail

        write_docs = kw.pop("write_docs")
        moved = []
        for name, f in fields.items():
            v = kw.get(name)
            if (not write_docs and isinstance(v, Path) and isinstance(f.default, Path) and v == f.default
                    and f.default.parts[:1] == DOCS.parts):
                kw[name] = REPRODUCED / f.default.relative_to(DOCS)
                moved.append(f"--{name.replace('_', '-')} {kw[name]}")
        try:
            p = experiment.Params(**kw)
        except ValidationError as e:  # the spec's messages: a range error states the whole range
            messages = [x["message"] for x in SpecError.from_validation(e, experiment.Params).errors]
            fail("; ".join(f"--{'.'.join(map(str, x['loc'])).replace('_', '-')}: {m}"
                           for x, m in zip(e.errors(), messages)))
        if moved:
            err.print(f"writing {', '.join(moved)} (docs/ is left as published; --write-docs to update it)",
                      highlight=False)
        print(experiment.run(p, err.print))
        if write_docs:  # the pages' generated sections follow the JSON just written
            from app.results.docs_gen import write

            for page in write():
                err.print(f"rewrote the generated sections of {page}", highlight=False)

    command.__signature__ = inspect.Signature(params)
    command.__annotations__ = annotations
    command.__doc__ = experiment.help
    return command


for _kind in KINDS.values():
    for _i, _exp in enumerate(_kind.experiments()):
        reproduce_app.command(_kind.name if _i == 0 else f"{_kind.name}-{_exp.name}")(_experiment_command(_exp))


def _cross_kind_experiments():
    """Reproductions that span the kinds: `gaitmend reproduce <name>` (app/cli/bench.py's
    measures every kind with the function `gaitmend bench` calls; app/cli/examples.py's runs
    the README's example lines through the CLI; app/adapt/reproduce's evaluates the
    adaptation methods of issue 44, which is no kind's; app/cli/machines.py re-runs the
    committed reference results on this machine)."""
    from app.adapt.reproduce.experiment import ANT_EXPERIMENT as ADAPT_ANT
    from app.adapt.reproduce.experiment import EXPERIMENT as ADAPT
    from app.cli.bench import EXPERIMENT as BENCH
    from app.cli.examples import EXPERIMENT as EXAMPLES
    from app.cli.machines import EXPERIMENT as MACHINES

    return [BENCH, EXAMPLES, ADAPT, ADAPT_ANT, MACHINES]


for _exp in _cross_kind_experiments():
    reproduce_app.command(_exp.name)(_experiment_command(_exp))


@cli.command()
def docs(check: bool = typer.Option(False, "--check", help="only compare: exit 1 and print the differences when a "
                                    "generated section's text differs from what its data renders")):
    """Rewrite every generated section of README.md and docs/*.md from the committed JSON
    under docs/ (each section's marker names the command that writes its data)."""
    from app.results.docs_gen import check as check_pages, write

    if check:
        diffs = check_pages()
        if diffs:
            print("\n\n".join(diffs))
            raise typer.Exit(1)
        print("every generated section matches its data")
        return
    for page in write():
        print(f"rewrote {page}")

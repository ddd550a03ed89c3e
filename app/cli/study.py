"""`gaitmend study submit|run|list`: studies on a server or locally (app/studies)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Optional

import typer

from app.cli.client import JsonOpt, ServerOpt, TokenOpt, _call, _client
from app.cli.common import cli, err, fail, out_console
from app.studies.catalog import builtin_studies, builtin_study, kind_studies

study_cli = typer.Typer(no_args_is_help=True, help="Studies: one spec that fans out into many jobs.")
cli.add_typer(study_cli, name="study")
BUILTIN_NAMES = ", ".join(builtin_studies())  # for the help texts: every kind's, in registry order


def _load(path: Path) -> dict:
    from app.api.body import BodyError, parse_json
    from app.studies.study_bundle import load_study_file

    if not path.exists() and (study := builtin_study(str(path))) is not None:
        return study
    try:
        return load_study_file(parse_json(path.read_bytes()))
    except OSError as e:
        fail(f"cannot read {path}: {e.strerror}")
    except BodyError as e:
        fail(f"{path}: not an acceptable JSON document: {e}")


def _plan(path: Path):
    from app.jobs.base import SpecError
    from app.studies.spec import expand

    data = _load(path)
    try:
        return data, expand(data)
    except SpecError as e:
        for x in e.errors:
            err.print(f"[bold red]error:[/] {x['field']}: {x['message']}", highlight=False)
        raise typer.Exit(2)


def _print_aggregate(agg: dict, title: str, infeasible: list[dict]) -> None:
    from app.studies.aggregate import to_markdown

    out_console().print(to_markdown(agg, title, infeasible), highlight=False, markup=False)


@study_cli.command("run")
def run(study_path: Path = typer.Argument(..., metavar="STUDY", help="study JSON, a study bundle's manifest.json, "
                                          f"or a built-in name: {BUILTIN_NAMES}"),
        out: Path = typer.Option(Path("results"), "--out", help="folder for the study's files"),
        workers: Optional[int] = typer.Option(None, "--workers", min=1, max=256, help="processes (default: all cores)"),
        bundles: bool = typer.Option(False, "--bundles", help="also write every point's job bundle "
                                     "(OUT/bundles/point-NNNN.zip), as the served study's workers do"),
        as_json: bool = JsonOpt):
    """Run every point of a study here, on all cores, with no server; writes the same
    files as the served study's bundle."""
    from app.studies.aggregate import aggregate
    from app.studies.study_bundle import study_files
    from app.studies.local import run_plan

    data, plan = _plan(study_path)
    err.print(f"{len(plan.points)} points, {plan.evaluations} evaluations; {len(plan.infeasible)} infeasible listed")
    t0 = time.monotonic()
    rows = run_plan(plan, workers, log=lambda s: err.print(s), bundle_dir=out / "bundles" if bundles else None)
    rep = plan.study.report
    agg = aggregate(rows, rep.group_by, rep.metrics)
    spec = plan.study.model_dump(mode="json", exclude_none=True)
    files = study_files(spec, rows, agg, plan.infeasible, {"wall_s": time.monotonic() - t0})
    out.mkdir(parents=True, exist_ok=True)
    for name, blob in files.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(blob)
    if as_json:
        print(json.dumps({"aggregate": agg, "out": str(out)}))
    else:
        _print_aggregate(agg, plan.study.name, plan.infeasible)
        err.print(f"{time.monotonic() - t0:.1f} s; files in {out}/")
    if any(r["status"] != "succeeded" for r in rows):
        raise typer.Exit(1)


@study_cli.command("submit")
def submit(study_path: Path = typer.Argument(..., metavar="STUDY", help="study JSON or a built-in name: "
                                             f"{BUILTIN_NAMES}"),
           server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt,
           wait: bool = typer.Option(False, "--wait", help="wait until every point has finished"),
           as_json: bool = JsonOpt):
    """Submit a study to a server (checked here first: exit 2 if a point is bad)."""
    data, plan = _plan(study_path)
    with _client(server, token) as c:
        st = _call(c, "POST", "/api/studies", content=json.dumps(data),
                   headers={"Content-Type": "application/json"}).json()
        if not as_json:
            print(st["id"], flush=True)
            err.print(f"study {st['id']}: {st['progress']['points']} points {st['status']}")
        last = None
        while wait and st["status"] in ("queued", "running"):
            time.sleep(1.0)
            st = _call(c, "GET", f"/api/studies/{st['id']}").json()
            pr = st["progress"]
            line = f"{pr['done']}/{pr['points']} done, {pr['running']} running, {pr['failed']} failed"
            if line != last and not as_json:
                err.print(line)
                last = line
    if as_json:
        print(json.dumps(st))
    elif wait:
        _print_aggregate(st["aggregate"], st["name"], st["infeasible"])
    if wait and st["status"] != "succeeded":
        raise typer.Exit(1)


@study_cli.command("show")
def show(study_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """A study's progress and aggregate."""
    with _client(server, token) as c:
        st = _call(c, "GET", f"/api/studies/{study_id}").json()
    if as_json:
        print(json.dumps(st))
        return
    pr = st["progress"]
    err.print(f"{st['name']}: {st['status']}, {pr['done']}/{pr['points']} done, {pr['running']} running, "
              f"{pr['failed']} failed")
    _print_aggregate(st["aggregate"], st["name"], st["infeasible"])


@study_cli.command("cancel")
def cancel(study_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt):
    """Cancel every point that has not finished."""
    with _client(server, token) as c:
        st = _call(c, "POST", f"/api/studies/{study_id}/cancel").json()
    err.print(f"study {st['id']}: {st['status']}")


# -- gaitmend reproduce <kind>-study: the kind's paper study, here or on a server ---------------

def _study_command(kind: str, names: list[str]):
    def command(name: str = typer.Argument(names[0], help=f"one of: {', '.join(names)}"),
                server: Optional[str] = typer.Option(None, "--server",
                                                     help="submit to this server and wait (default: run here)"),
                token: Optional[str] = TokenOpt,
                workers: Optional[int] = typer.Option(None, "--workers", min=1, max=256,
                                                      help="processes when run here (default: all cores)"),
                out: Path = typer.Option(Path("reproduced") / "studies", "--out",
                                         help="parent folder for the study's files when run here"),
                as_json: bool = JsonOpt):
        if name not in names:
            fail(f"NAME: unknown study {name!r} for {kind}; allowed: {', '.join(names)}")
        if server:
            submit(Path(name), server=server, token=token, wait=True, as_json=as_json)
        else:
            run(Path(name), out=out / name, workers=workers, bundles=False, as_json=as_json)

    command.__doc__ = (f"Run {kind}'s paper study as parallel jobs: {', '.join(names)} (built-in studies; "
                       f"`gaitmend study run NAME` does the same). Here on all cores, or on a server's workers "
                       f"with --server.")
    return command


def _register_reproduce_studies() -> None:
    from app.cli.local import reproduce_app
    from app.jobs.registry import KINDS

    for kind in KINDS:
        if names := kind_studies(kind):
            reproduce_app.command(f"{kind}-study")(_study_command(kind, names))


_register_reproduce_studies()

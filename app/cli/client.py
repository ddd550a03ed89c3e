"""Client commands of `gaitmend`: submit, jobs, fetch, cancel (HTTP API) and replay."""

from __future__ import annotations

import contextlib
import json
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Optional

import typer
from rich.markup import escape

from app.cli.common import cli, err, fail, load_spec, out_console, settings_or_exit
from app.client import Client, GaitmendError
from app.client.jobs import FINAL


@contextlib.contextmanager
def _client(server: Optional[str], token: Optional[str]) -> Iterator[Client]:
    """The Python client (app/client) for a command; its errors become the CLI's: each
    field and message on stderr, exit 2 for a request the server refused as wrong (400,
    404, 409, 413, 422), 1 for anything else (no server, 401, 5xx)."""
    settings = settings_or_exit()
    try:
        with Client(server or settings.server, token or settings.token) as c:
            yield c
    except GaitmendError as e:
        if e.status is None:
            fail(e.detail, code=1)
        for m in [f"{x['field']}: {x['message']}" for x in e.errors] or [e.detail]:
            err.print("[bold red]error:[/] " + escape(str(m)), highlight=False)  # the API's text, not markup
        raise typer.Exit(2 if e.status in (400, 404, 409, 413, 422) else 1) from None


def _call(client: Client, method: str, url: str, **kw):
    """One request through the client (its errors end the command in ``_client``)."""
    return client.request(method, url, **kw)


ServerOpt = typer.Option(None, "--server", help="API base URL (default GAITMEND_SERVER, http://127.0.0.1:8000)")
TokenOpt = typer.Option(None, "--token", help="API token (default GAITMEND_TOKEN)")
JsonOpt = typer.Option(False, "--json", help="print JSON on stdout")


def _progress_text(kind_name: str, info: dict) -> str:
    from app.jobs.registry import KINDS

    kind = KINDS.get(kind_name)  # a server may know kinds this client does not
    return kind.progress_text(info) if kind is not None and info else ""


def _wait(client: Client, job_id: str, quiet: bool) -> dict:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    progress = None if quiet else Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                           TextColumn("{task.fields[state]}"), TimeElapsedColumn(), console=err)
    task = progress.add_task(job_id[:8], total=None, state="queued") if progress else None

    def show(job: dict) -> None:
        p = job["progress"]
        text = _progress_text(job["kind"], p.get("info") or {})
        progress.update(task, completed=p["done"], total=p["total"] or None,
                        state=job["status"] + (f"  {text}" if text else ""))

    with (progress or contextlib.nullcontext()):
        return client.poll(f"/api/jobs/{job_id}", lambda j: j["status"] in FINAL, show if progress else None)


@cli.command()
def submit(spec_path: Path = typer.Argument(..., metavar="SPEC", help="spec JSON, a bundle's manifest.json or a bundle zip"),
           server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt,
           wait: bool = typer.Option(False, "--wait", help="wait for the job to finish, with a progress bar"),
           idempotency_key: Optional[str] = typer.Option(None, "--idempotency-key",
                                                         help="resubmitting with the same key returns the same job"),
           as_json: bool = JsonOpt):
    """Submit a job to a server. The spec is checked here first (exit 2 if it is bad)."""
    spec = load_spec(spec_path)
    with _client(server, token) as c:
        job = c.submit(spec, idempotency_key=idempotency_key).info
        if not as_json:
            # The id goes out at once (stdout, flushed), so a script can cancel the job while it runs.
            print(job["id"], flush=True)
            err.print(f"job {job['id']} {job['status']}")
        if wait:
            job = _wait(c, job["id"], quiet=as_json)
    if as_json:
        print(json.dumps(job))
    elif wait:
        _say_outcome(job)
    if wait and job["status"] != "succeeded":
        raise typer.Exit(1)


def _say_outcome(job: dict) -> None:
    if job["status"] == "succeeded":
        err.print(f"succeeded in {job['wall_s'] or 0:.1f} s" + (f"; {_headline_text(job)}" if job.get("headline") else ""),
                  highlight=False)
    elif job["status"] == "cancelled":
        why = job.get("error") or ("cancelled on request" if job.get("cancel_requested") else "cancelled")
        err.print(f"cancelled: {why}", highlight=False)
    else:
        err.print(f"{job['status']}: {job.get('error') or 'no reason recorded'}", highlight=False)


def _headline_text(job: dict, first: int | None = None) -> str:
    rows = (job.get("headline") or [])[:first]
    out = []
    for r in rows:
        v = r["value"]
        v = f"{v:.4g}" if isinstance(v, float) else ("-" if v is None else str(v))
        out.append(f"{r['label']} {v}{(' ' + r['unit']) if r.get('unit') else ''}")
    return "; ".join(out)


SHORT_ID = 8  # ids are shown this long; any unique prefix (6 or more hex digits) is accepted


@cli.command()
def jobs(job_id: Optional[str] = typer.Argument(None, help="show one job (its id or a unique prefix of it)"),
         status: Optional[str] = typer.Option(None, help="queued, running, succeeded, failed or cancelled"),
         kind: Optional[str] = typer.Option(None), robot: Optional[str] = typer.Option(None),
         limit: int = typer.Option(20, min=1, max=500),
         server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """List jobs (newest first) with their damage and headline value, or show one job."""
    if status is not None and status not in ("queued", "running", "succeeded", "failed", "cancelled"):
        fail(f"--status: one of queued, running, succeeded, failed, cancelled; got {status!r}")
    with _client(server, token) as c:
        if job_id:
            job = c.job(job_id).info
            if as_json:
                print(json.dumps(job))
            else:
                _show_job(job)
            return
        params = {k: v for k, v in {"status": status, "kind": kind, "robot": robot, "limit": limit}.items() if v}
        page = c.get_json("/api/jobs", **params)
    if as_json:
        print(json.dumps(page))
        return
    from rich.table import Table

    t = Table()
    for col in ("id", "kind", "robot", "damage", "status", "progress", "headline", "created"):
        t.add_column(col, overflow="fold")
    for j in page["items"]:
        p = j["progress"]
        t.add_row(j["id"][:SHORT_ID], j["kind"], j["robot"] or "", j["damage"], j["status"],
                  f"{p['done']}/{p['total']}", _headline_text(j, first=1) or "-", j["created_at"][:19])
    out_console().print(t)
    if page.get("next_cursor"):
        err.print(f"(newest {len(page['items'])} shown; --limit N for more)")


def _show_job(job: dict) -> None:
    """One job for a person: status, timings, error, the kind's headline and tables."""
    from app.cli.common import print_tables
    from app.jobs.registry import KINDS

    con = out_console()
    p = job["progress"]
    lines = [f"job {job['id']}  {job['kind']}  robot {job['robot'] or '-'}  owner {job['owner']}",
             f"status {job['status']}" + (" (cancel requested)" if job["cancel_requested"] and job["status"] == "running"
                                          else "") + f"  progress {p['done']}/{p['total']}  attempt {job['attempt']}",
             f"damage {job['damage']}",
             f"created {job['created_at'][:19]}  started {(job['started_at'] or '-')[:19]}  "
             f"finished {(job['finished_at'] or '-')[:19]}" + (f"  wall {job['wall_s']:.1f} s" if job["wall_s"] else "")]
    if job.get("error"):
        lines.append(f"error: {job['error']}")
    for line in lines:
        con.print(line, highlight=False)
    kind = KINDS.get(job["kind"])
    if job.get("summary") and kind is not None:
        try:
            print_tables(kind.summary_tables(job["summary"]), con)
        except (KeyError, TypeError, ValueError, IndexError):  # a summary of another version
            con.print(_headline_text(job), highlight=False)
    elif job.get("headline"):
        con.print(_headline_text(job), highlight=False)
    con.print(f"(full JSON: gaitmend jobs {job['id'][:SHORT_ID]} --json; bundle: gaitmend fetch {job['id'][:SHORT_ID]})",
              highlight=False)


@cli.command()
def fetch(job_id: str = typer.Argument(...), out: Path = typer.Option(Path("."), "--out", help="folder for the zip"),
          server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """Download a finished job's result bundle (zip)."""
    with _client(server, token) as c:
        job = c.job(job_id)  # a prefix resolves to the full id
        path = job.bundle(out)
    if as_json:
        print(json.dumps({"id": job.id, "bundle": str(path), "bytes": path.stat().st_size}))
    else:
        print(path)


@cli.command()
def cancel(job_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """Cancel a job: a queued one never starts, a running one stops within a generation."""
    with _client(server, token) as c:
        job = c.cancel(job_id)
    print(json.dumps(job) if as_json else f"{job['id']} {job['status']}"
          + (" (cancel requested)" if job["status"] == "running" else ""))


@cli.command()
def retry(job_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """Run a failed or cancelled job again; it resumes from its last checkpoint."""
    with _client(server, token) as c:
        job = c.retry(job_id)
    print(json.dumps(job) if as_json else f"{job['id']} {job['status']}")


@cli.command()
def delete(job_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt,
           as_json: bool = JsonOpt):
    """Delete a job that is not running, with its history, checkpoint and bundle."""
    with _client(server, token) as c:
        full = c.delete(job_id)  # a prefix resolves to the full id first
    print(json.dumps({"id": full, "deleted": True}) if as_json else f"{full} deleted")


@cli.command()
def replay(
    target: str = typer.Argument(..., help="a bundle (.zip or unpacked folder) or a job id on --server"),
    host: str = typer.Option("127.0.0.1", help="address the viser server binds"),
    port: int = typer.Option(8081, min=1, max=65535),
    server: str = typer.Option("http://127.0.0.1:8000", "--server", envvar="GAITMEND_SERVER",
                               help="API to fetch the bundle of a job id from"),
    token: Optional[str] = typer.Option(None, envvar="GAITMEND_TOKEN", help="API token for --server"),
):
    """Open a live 3D replay (timeline, play/pause, speed, recovered/baseline toggle)."""
    import io

    import mujoco
    import numpy as np

    from app.results.replay import replay_tracks, serve_live

    path = Path(target)
    if not path.exists() and (path.suffix == ".zip" or "/" in target or "\\" in target or target.startswith(".")):
        fail(f"no such bundle file or folder: {target} (a job id has no '/' or '.zip')")
    try:
        if path.is_dir():
            files = {p.relative_to(path).as_posix(): p.read_bytes() for p in path.rglob("*") if p.is_file()}
        else:
            if path.is_file():
                blob = path.read_bytes()
            else:
                with _client(server, token or "") as c:
                    blob = c.request("GET", f"/api/jobs/{target}/bundle", timeout=60).content
            with zipfile.ZipFile(io.BytesIO(blob)) as z:
                files = {n: z.read(n) for n in z.namelist()}
    except (OSError, zipfile.BadZipFile) as e:
        fail(f"cannot load bundle {target!r}: {e}")
    if "robot.xml" not in files:
        fail(f"{target!r} is not a gaitmend bundle (no robot.xml)")
    model = mujoco.MjModel.from_xml_string(files["robot.xml"].decode())
    traces = {}
    for name, data in sorted(files.items()):
        if name.startswith("trajectories/") and name.endswith(".npz"):
            tr = dict(np.load(io.BytesIO(data)))
            if "qpos" in tr:
                traces[name[len("trajectories/"):-4]] = tr
    if not traces:
        fail(f"{target!r} has no replayable trajectories")
    kind = _bundle_kind(files)
    tracks = replay_tracks(kind, list(traces))
    err.print(f"replay of {', '.join(t.label for t in tracks)} on http://{host}:{port} (Ctrl-C to stop)")
    serve_live(model, {t.name: traces[t.name] for t in tracks}, host=host, port=port, tracks=tracks)


def _bundle_kind(files: dict[str, bytes]):
    from app.jobs.registry import KINDS

    try:
        return KINDS.get(json.loads(files["manifest.json"])["kind"])
    except (KeyError, ValueError):
        return None

"""Client commands of `gaitmend`: submit, jobs, fetch, cancel (HTTP API) and replay."""

from __future__ import annotations

import json
import time
import zipfile
from pathlib import Path
from typing import Optional

import typer

from app.cli.common import cli, err, fail, load_spec, settings_or_exit

FINAL = ("succeeded", "failed", "cancelled")


def _client(server: Optional[str], token: Optional[str]):
    import httpx

    settings = settings_or_exit()
    base = (server or settings.server).rstrip("/")
    tok = token or settings.token
    headers = {"Authorization": f"Bearer {tok}"} if tok else {}
    return httpx.Client(base_url=base, headers=headers, timeout=30.0)


def _call(client, method: str, url: str, **kw):
    import httpx

    try:
        r = client.request(method, url, **kw)
    except httpx.HTTPError as e:
        fail(f"cannot reach {client.base_url}: {e}", code=1)
    if r.status_code >= 400:
        try:
            body = r.json()
            msgs = [f"{e['field']}: {e['message']}" for e in body.get("errors", [])] or [body.get("detail", r.text)]
        except ValueError:
            msgs = [r.text]
        for m in msgs:
            err.print(f"[bold red]error:[/] {m}", highlight=False)
        raise typer.Exit(2 if r.status_code in (400, 404, 409, 413, 422) else 1)
    return r


ServerOpt = typer.Option(None, "--server", help="API base URL (default GAITMEND_SERVER, http://127.0.0.1:8000)")
TokenOpt = typer.Option(None, "--token", help="API token (default GAITMEND_TOKEN)")
JsonOpt = typer.Option(False, "--json", help="print JSON on stdout")


def _progress_text(kind_name: str, info: dict) -> str:
    from app.jobs.registry import KINDS

    kind = KINDS.get(kind_name)  # a server may know kinds this client does not
    return kind.progress_text(info) if kind is not None and info else ""


def _wait(client, job_id: str, quiet: bool) -> dict:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    progress = None if quiet else Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                           TextColumn("{task.fields[state]}"), TimeElapsedColumn(), console=err)
    task = progress.add_task(job_id[:8], total=None, state="queued") if progress else None
    if progress:
        progress.start()
    try:
        while True:
            job = _call(client, "GET", f"/api/jobs/{job_id}").json()
            if progress:
                p = job["progress"]
                info = p.get("info") or {}
                text = _progress_text(job["kind"], info)
                state = job["status"] + (f"  {text}" if text else "")
                progress.update(task, completed=p["done"], total=p["total"] or None, state=state)
            if job["status"] in FINAL:
                return job
            time.sleep(0.5)
    finally:
        if progress:
            progress.stop()


@cli.command()
def submit(spec_path: Path = typer.Argument(..., metavar="SPEC", help="spec JSON, a bundle's manifest.json or a bundle zip"),
           server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt,
           wait: bool = typer.Option(False, "--wait", help="wait for the job to finish, with a progress bar"),
           idempotency_key: Optional[str] = typer.Option(None, "--idempotency-key",
                                                         help="resubmitting with the same key returns the same job"),
           as_json: bool = JsonOpt):
    """Submit a job to a server. The spec is checked here first (exit 2 if it is bad)."""
    spec = load_spec(spec_path)
    headers = {"Idempotency-Key": idempotency_key} if idempotency_key else {}
    with _client(server, token) as c:
        job = _call(c, "POST", "/api/jobs", content=spec.model_dump_json(), headers=headers
                    | {"Content-Type": "application/json"}).json()
        if not as_json:
            err.print(f"job {job['id']} {job['status']}")
        if wait:
            job = _wait(c, job["id"], quiet=as_json)
    if as_json:
        print(json.dumps(job))
    else:
        print(job["id"])
        if job["status"] in ("failed", "cancelled"):
            err.print(f"{job['status']}: {job.get('error') or ''}")
    if wait and job["status"] != "succeeded":
        raise typer.Exit(1)


@cli.command()
def jobs(job_id: Optional[str] = typer.Argument(None, help="show one job"),
         status: Optional[str] = typer.Option(None, help="queued, running, succeeded, failed or cancelled"),
         kind: Optional[str] = typer.Option(None), robot: Optional[str] = typer.Option(None),
         limit: int = typer.Option(20, min=1, max=500),
         server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """List jobs (newest first), or show one."""
    if status is not None and status not in ("queued", "running", "succeeded", "failed", "cancelled"):
        fail(f"--status: one of queued, running, succeeded, failed, cancelled; got {status!r}")
    with _client(server, token) as c:
        if job_id:
            job = _call(c, "GET", f"/api/jobs/{job_id}").json()
            print(json.dumps(job, indent=None if as_json else 2))
            return
        params = {k: v for k, v in {"status": status, "kind": kind, "robot": robot, "limit": limit}.items() if v}
        page = _call(c, "GET", "/api/jobs", params=params).json()
    if as_json:
        print(json.dumps(page))
        return
    from rich.console import Console
    from rich.table import Table

    t = Table()
    for col in ("id", "kind", "robot", "status", "progress", "attempt", "created"):
        t.add_column(col)
    for j in page["items"]:
        p = j["progress"]
        t.add_row(j["id"], j["kind"], j["robot"] or "", j["status"], f"{p['done']}/{p['total']}", str(j["attempt"]),
                  j["created_at"][:19])
    Console().print(t)


@cli.command()
def fetch(job_id: str = typer.Argument(...), out: Path = typer.Option(Path("."), "--out", help="folder for the zip"),
          server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """Download a finished job's result bundle (zip)."""
    with _client(server, token) as c:
        r = _call(c, "GET", f"/api/jobs/{job_id}/bundle")
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"gaitmend-{job_id}.zip"
    tmp = path.with_suffix(".zip.part")
    tmp.write_bytes(r.content)
    tmp.replace(path)
    if as_json:
        print(json.dumps({"id": job_id, "bundle": str(path), "bytes": len(r.content)}))
    else:
        print(path)


@cli.command()
def cancel(job_id: str, server: Optional[str] = ServerOpt, token: Optional[str] = TokenOpt, as_json: bool = JsonOpt):
    """Cancel a job: a queued one never starts, a running one stops within a generation."""
    with _client(server, token) as c:
        job = _call(c, "POST", f"/api/jobs/{job_id}/cancel").json()
    print(json.dumps(job) if as_json else f"{job['id']} {job['status']}"
          + (" (cancel requested)" if job["status"] == "running" else ""))


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

    from app.replay import replay_tracks, serve_live

    path = Path(target)
    try:
        if path.is_dir():
            files = {p.relative_to(path).as_posix(): p.read_bytes() for p in path.rglob("*") if p.is_file()}
        else:
            if path.is_file():
                blob = path.read_bytes()
            else:
                import urllib.request

                req = urllib.request.Request(f"{server.rstrip('/')}/api/jobs/{target}/bundle")
                if token:
                    req.add_header("Authorization", f"Bearer {token}")
                with urllib.request.urlopen(req, timeout=60) as r:
                    blob = r.read()
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

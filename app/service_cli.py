"""Service commands of the `gaitmend` CLI: serve, worker, db, token (server side) and
submit, jobs, fetch, cancel (HTTP client). Registered on app.cli's `cli`."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Optional

import typer

from app.cli import cli, err, fail, load_spec
from app.settings import Settings, SettingsError, load_settings

db_app = typer.Typer(no_args_is_help=True, help="Database schema (Alembic migrations).")
token_app = typer.Typer(no_args_is_help=True, help="API tokens (stored hashed).")
cli.add_typer(db_app, name="db")
cli.add_typer(token_app, name="token")

FINAL = ("succeeded", "failed", "cancelled")
# `python -m app.cli` would load a second copy of app.cli without these commands.
ENTRY = "from app.cli import main; main()"


def settings_or_exit() -> Settings:
    try:
        return load_settings()
    except SettingsError as e:
        fail(f"bad settings: {e}")


def _upgrade(settings: Settings) -> None:
    from app.store.migrate import upgrade

    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.db_url)


# -- server side ----------------------------------------------------------------------------

class EmbeddedWorker:
    """`gaitmend worker` as a child of `gaitmend serve`, restarted if it dies."""

    def __init__(self):
        self.proc: subprocess.Popen | None = None
        self.stopping = threading.Event()

    def start(self) -> None:
        self._spawn()
        threading.Thread(target=self._watch, name="embedded-worker", daemon=True).start()

    def _spawn(self) -> None:
        env = os.environ | {"GAITMEND_PARENT_PID": str(os.getpid())}
        self.started = time.monotonic()
        self.proc = subprocess.Popen([sys.executable, "-c", ENTRY, "worker"], env=env, start_new_session=True)

    def _watch(self) -> None:
        backoff = 1.0
        while not self.stopping.wait(1.0):
            if self.proc.poll() is None or self.stopping.is_set():
                continue
            # One that dies right after starting (bad settings, database away) is retried
            # ever more slowly rather than in a tight loop.
            quick = time.monotonic() - self.started < 10
            backoff = min(backoff * 2, 30.0) if quick else 1.0
            err.print(f"embedded worker exited ({self.proc.returncode}); restarting it"
                      + (f" in {backoff:.0f} s" if quick else ""))
            if quick and self.stopping.wait(backoff):
                return
            self._spawn()

    def stop(self) -> None:
        self.stopping.set()
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


@cli.command()
def serve(host: str = typer.Option("127.0.0.1", help="address to bind; any non-loopback address requires API tokens"),
          port: int = typer.Option(8000, min=1, max=65535, help="TCP port"),
          worker: bool = typer.Option(True, help="with the embedded broker, also run one worker process")):
    """Apply migrations, then serve the API (and, with the embedded broker, one worker)."""
    import uvicorn

    from app.api import create_app
    from app.api.auth import auth_required

    settings = settings_or_exit()
    _upgrade(settings)
    if auth_required(settings.auth, host):
        from app.store import repo
        from app.store.db import session_scope

        with session_scope(settings.db_url, readonly=True) as s:
            if repo.token_count(s) == 0:
                err.print("[yellow]warning:[/] auth is required on this address and no token exists yet: "
                          "create one with `gaitmend token create NAME`")
    embedded = EmbeddedWorker() if (settings.embedded_broker and worker) else None
    if embedded:
        embedded.start()
    err.print(f"gaitmend API on http://{host}:{port} (docs: /docs); data in {settings.data_dir.resolve()}; "
              f"broker {'embedded' if settings.embedded_broker else 'redis'}"
              + ("; one embedded worker" if embedded else ""))
    try:
        uvicorn.run(create_app(settings, host=host, housekeeping=True), host=host, port=port, log_level="warning",
                    access_log=False)
    finally:
        if embedded:
            embedded.stop()


@cli.command()
def worker(concurrency: Optional[int] = typer.Option(None, min=1, max=64,
                                                     help="task slots (processes); default GAITMEND_WORKER_CONCURRENCY"),
           loglevel: str = typer.Option("INFO", help="Celery log level")):
    """Run a Celery worker for the job queue (run as many as you like, on any machine)."""
    settings = settings_or_exit()
    from app.store.migrate import at_head

    try:
        ok = at_head(settings.db_url)
    except Exception as e:
        fail(f"cannot reach the database {settings.db_url.split('@')[-1]}: {e}", code=1)
    if not ok:
        fail("the database schema is not up to date: run `gaitmend db upgrade` (or `gaitmend serve`)", code=1)
    _watch_parent()
    from workers.celery_app import celery_app

    celery_app.worker_main(["worker", f"--loglevel={loglevel}", "-Q", settings.queue,
                            "-c", str(concurrency or settings.worker_concurrency), "--pool=prefork",
                            "--without-gossip", "--without-mingle", "--without-heartbeat",
                            "-n", f"gaitmend.{os.getpid()}@%h"])


def _watch_parent() -> None:
    """An embedded worker stops (warm shutdown) when its `gaitmend serve` is gone."""
    parent = os.environ.get("GAITMEND_PARENT_PID")
    if not parent:
        return

    def watch():
        while True:
            time.sleep(1.0)
            if os.getppid() != int(parent):
                os.kill(os.getpid(), signal.SIGTERM)
                return

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


@db_app.command("upgrade")
def db_upgrade(revision: str = typer.Argument("head")):
    """Apply migrations up to REVISION (default head)."""
    from app.store.migrate import current, upgrade

    settings = settings_or_exit()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.db_url, revision)
    print(current(settings.db_url))


@db_app.command("current")
def db_current():
    """Print the schema revision of the database."""
    from app.store.migrate import current, head

    settings = settings_or_exit()
    cur = current(settings.db_url)
    print(f"{cur or '(empty)'} (head: {head(settings.db_url)})")


@token_app.command("create")
def token_create(name: str = typer.Argument(..., help="owner name of the token's jobs (letters, digits, -_.)")):
    """Create a token; it is printed once and only its hash is stored."""
    import re

    from app.store import repo
    from app.store.db import session_scope

    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", name):
        fail(f"NAME: 1-64 letters, digits, '-', '_' or '.', got {name!r}")
    settings = settings_or_exit()
    _upgrade(settings)
    try:
        with session_scope(settings.db_url) as s:
            token = repo.create_token(s, name)
    except repo.Conflict as e:
        fail(str(e))
    print(token)


@token_app.command("list")
def token_list(as_json: bool = typer.Option(False, "--json")):
    """Token names and when they were created and last used (never the tokens)."""
    from app.store import repo
    from app.store.db import session_scope

    settings = settings_or_exit()
    with session_scope(settings.db_url, readonly=True) as s:
        rows = [{"name": t.name, "created_at": t.created_at.isoformat(),
                 "last_used_at": t.last_used_at.isoformat() if t.last_used_at else None} for t in repo.list_tokens(s)]
    if as_json:
        print(json.dumps(rows))
    else:
        for r in rows:
            print(f"{r['name']:24s} created {r['created_at']}  last used {r['last_used_at'] or '-'}")


@token_app.command("revoke")
def token_revoke(name: str):
    """Delete a token; requests with it fail from now on."""
    from app.store import repo
    from app.store.db import session_scope

    settings = settings_or_exit()
    with session_scope(settings.db_url) as s:
        if not repo.revoke_token(s, name):
            fail(f"no token named {name!r}", code=1)
    print(f"revoked {name}")


# -- client side ------------------------------------------------------------------------------

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
                state = job["status"] + (f"  best F {info['best']:.4f}" if "best" in info else "")
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

"""Server commands of `gaitmend`: serve (API + embedded worker), worker, db, token."""

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

from app.cli.common import cli, err, fail, settings_or_exit
from app.core.settings import Settings

db_app = typer.Typer(no_args_is_help=True, help="Database schema (Alembic migrations).")
token_app = typer.Typer(no_args_is_help=True, help="API tokens (stored hashed).")
cli.add_typer(db_app, name="db")
cli.add_typer(token_app, name="token")

# The worker child runs the same CLI (`python -m app.cli` would import the package twice).
ENTRY = "from app.cli import main; main()"


def _upgrade(settings: Settings) -> None:
    from app.store.migrate import upgrade

    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.db_url)


def _safe_url(url: str) -> str:
    """A URL to print: the password hidden."""
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True) if "://" in url else url
    except Exception:  # noqa: BLE001  (not an SQLAlchemy URL, e.g. redis://): drop the credentials
        return url.split("@")[-1] if "@" in url else url


def _database_exists(settings: Settings) -> bool:
    """A database with gaitmend's tables (an SQLite file that exists, or a migrated server)."""
    from app.store.backup import sqlite_path
    from app.store.migrate import current

    path = sqlite_path(settings.db_url)
    if path is not None and not path.is_file():
        return False
    try:
        return current(settings.db_url) is not None
    except Exception:  # noqa: BLE001  (unreachable server: not a database to write a token into)
        return False


def _token_database(settings: Settings, init: bool | None = None) -> str:
    """The database the token commands use, as printable text. Where there is none: create it
    when ``init`` is True (token create --init), else exit 2 creating nothing (``init`` False:
    the command offers --init; None: it does not, as list and revoke have nothing to do in a
    new database)."""
    where = _safe_url(settings.db_url)
    if not _database_exists(settings):
        if not init:
            fail(f"no gaitmend database at {where} (GAITMEND_DATA_DIR / GAITMEND_DATABASE_URL: run this where the "
                 "server runs" + (")" if init is None else ", or pass --init to create a new database here)"))
        _upgrade(settings)
    return where


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
    _port_free_or_exit(host, port)
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


def _port_free_or_exit(host: str, port: int) -> None:
    """Fail before printing a URL or starting a worker when the port is taken."""
    import socket

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as e:
        fail(f"--host {host}: {e}")
    family, _, _, _, addr = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds
        try:
            sock.bind(addr)
        except OSError as e:
            fail(f"cannot listen on {host}:{port}: {e.strerror} (another server there? choose --port)", code=1)


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
    from app.service.dispatch import broker_ok

    reachable, why = broker_ok(settings)
    if not reachable:
        fail(f"cannot reach the broker {_safe_url(settings.broker_url)}: {why} (GAITMEND_BROKER_URL)", code=1)
    _watch_parent()
    from app.sim.threads import ENV, available_cpus

    slots = concurrency or settings.worker_concurrency
    # Each pool process's rollouts get their share of the cores (unless set explicitly).
    os.environ.setdefault(ENV, str(max(1, available_cpus() // slots)))
    from workers.celery_app import celery_app

    celery_app.worker_main(["worker", f"--loglevel={loglevel}", "-Q", settings.queue,
                            "-c", str(slots), "--pool=prefork",
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


@db_app.command("backup")
def db_backup(path: Path = typer.Argument(..., help="file to write the copy to"),
              force: bool = typer.Option(False, "--force", help="replace PATH if it exists")):
    """Copy the SQLite database consistently while the server runs (copying gaitmend.db alone
    misses what is still in its write-ahead log). PostgreSQL: use pg_dump, as it says."""
    from app.store.backup import BackupError, backup

    settings = settings_or_exit()
    try:
        info = backup(settings.db_url, path, overwrite=force)
    except BackupError as e:
        fail(str(e))
    print(f"{info['dest']}: {info['bytes']} bytes, {info['jobs']} jobs (from {info['source']})")


@db_app.command("current")
def db_current():
    """Print the schema revision of the database."""
    from app.store.migrate import current, head

    settings = settings_or_exit()
    cur = current(settings.db_url)
    print(f"{cur or '(empty)'} (head: {head(settings.db_url)})")


@token_app.command("create")
def token_create(name: str = typer.Argument(..., help="owner name of the token's jobs (letters, digits, -_.)"),
                 init: bool = typer.Option(False, "--init", help="create the database if there is none yet")):
    """Create a token; it is printed once and only its hash is stored."""
    import re

    from app.store import repo
    from app.store.db import session_scope

    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", name):
        fail(f"NAME: 1-64 letters, digits, '-', '_' or '.', got {name!r}")
    settings = settings_or_exit()
    where = _token_database(settings, init=init)
    try:
        with session_scope(settings.db_url) as s:
            token = repo.create_token(s, name)
    except repo.Conflict as e:
        fail(str(e))
    print(token)
    err.print(f"token {name!r} stored in {where}; it is shown only this once", highlight=False)


@token_app.command("list")
def token_list(as_json: bool = typer.Option(False, "--json")):
    """Token names and when they were created and last used (never the tokens)."""
    from app.store import repo
    from app.store.db import session_scope

    settings = settings_or_exit()
    where = _token_database(settings)
    with session_scope(settings.db_url, readonly=True) as s:
        rows = [{"name": t.name, "created_at": t.created_at.isoformat(),
                 "last_used_at": t.last_used_at.isoformat() if t.last_used_at else None} for t in repo.list_tokens(s)]
    err.print(f"{len(rows)} token{'' if len(rows) == 1 else 's'} in {where}", highlight=False)
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
    where = _token_database(settings)
    with session_scope(settings.db_url) as s:
        if not repo.revoke_token(s, name):
            fail(f"no token named {name!r} in {where}", code=1)
    print(f"revoked {name} in {where}")

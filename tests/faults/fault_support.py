"""A throw-away deployment of real processes for fault injection: `gaitmend serve` and
`gaitmend worker`s in their own process groups, a private Redis that can be killed and
restarted on its port, PostgreSQL backends that can be terminated by application name,
an API watcher that records every answer and every /api/health verdict, and the checks
every fault test ends with (results identical to an undisturbed run, no duplicate, no
job error holding SQL or a token, every 5xx a JSON 503 with Retry-After)."""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import threading
import time
import uuid
from pathlib import Path

import httpx
from service_support import Proc, comparable, deployment, free_port, reference_result, settings_of, wait_for
from sqlalchemy import select

from app.store.db import session_scope
from app.store.models import FINAL, Job

KINDS_DIR = str(Path(__file__).resolve().parents[1] / "kinds")
EXTRA = {"GAITMEND_EXTRA_KINDS": "ballistic:KIND"}


def ballistic(generations: int, population: int = 16, seed: int = 5, duration_s: float = 1.5) -> dict:
    return {"kind": "ballistic", "duration_s": duration_s,
            "search": {"population": population, "generations": generations, "seed": seed}}


_references: dict[str, dict] = {}


def reference(spec: dict) -> dict:
    """The undisturbed result of a spec (in this process, once per spec). The test kind is
    registered for the run only: other tests iterate over the registry."""
    from app.jobs import registry

    key = json.dumps(spec, sort_keys=True)
    if key not in _references:
        before = dict(registry.KINDS)
        registry._load_extra(EXTRA["GAITMEND_EXTRA_KINDS"])
        try:
            _references[key] = comparable(reference_result(spec))
        finally:
            registry.KINDS.clear()
            registry.KINDS.update(before)
    return _references[key]


class PrivateRedis:
    """redis-server on its own port and folder; kill() is SIGKILL, start() the same port."""

    def __init__(self, folder: Path, persist: bool = False):
        self.folder, self.port, self.persist = folder, free_port(), persist
        folder.mkdir(parents=True, exist_ok=True)
        self.proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self, persist: bool | None = None) -> None:
        persist = self.persist if persist is None else persist
        args = ["redis-server", "--port", str(self.port), "--bind", "127.0.0.1", "--dir", str(self.folder),
                "--save", "", "--appendonly", "yes" if persist else "no"]
        self.proc = subprocess.Popen(args, stdout=open(self.folder / "redis.log", "ab"), stderr=subprocess.STDOUT)
        import redis

        r = redis.Redis(port=self.port, socket_connect_timeout=0.5)
        wait_for(lambda: _ping(r), 20, "the private redis")

    def kill(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)

    def close(self) -> None:
        self.kill()


def _ping(r) -> bool:
    try:
        return r.ping()
    except Exception:  # noqa: BLE001
        return False


class Watcher:
    """Polls the API in a thread: every answer of the routes it reads is recorded, and
    every /api/health verdict with its time."""

    def __init__(self, base: str, paths: list[str], every_s: float = 0.3):
        self.base, self.paths, self.every_s = base, list(paths), every_s
        self.health: list[tuple[float, str, list[str]]] = []
        self.answers: list[tuple[str, int, dict, str]] = []
        self.stop = threading.Event()
        self.t = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        self.t.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.t.join(10)

    def _run(self) -> None:
        with httpx.Client(timeout=10) as c:
            while not self.stop.is_set():
                for path in ["/api/health", *self.paths]:
                    try:
                        r = c.get(self.base + path)
                    except httpx.HTTPError as e:
                        self.answers.append((path, 0, {}, str(e)))
                        continue
                    self.answers.append((path, r.status_code, dict(r.headers), r.text))
                    if path == "/api/health" and r.status_code == 200:
                        h = r.json()
                        self.health.append((time.monotonic(), h["status"], h.get("reasons") or []))
                self.stop.wait(self.every_s)


def check_answers(answers) -> int:
    """No 5xx but a JSON 503 with Retry-After naming no SQL. Returns the 503s seen."""
    seen = 0
    for path, status, headers, body in answers:
        if status < 500:
            continue
        assert status == 503, f"{path} answered {status}: {body[:300]}"
        data = json.loads(body)
        assert set(data) == {"detail", "errors"} and data["detail"], body
        assert int(headers.get("retry-after", "0")) > 0, headers
        assert "[SQL" not in body and "SELECT" not in body and "UPDATE" not in body, body
        seen += 1
    return seen


_HEX32 = re.compile(r"\b[0-9a-f]{32}\b")


def check_errors(settings) -> None:
    """Every job error written: no SQL, no parameters, no 32-hex token but the job's id."""
    with session_scope(settings.db_url, readonly=True) as s:
        rows = list(s.execute(select(Job.id, Job.error, Job.lease_token).where(Job.error.is_not(None))))
    for jid, error, _ in rows:
        assert "[SQL" not in error and "[parameters" not in error, error
        assert not re.search(r"\b(SELECT|UPDATE|INSERT|DELETE)\b", error), error
        assert all(h == jid for h in _HEX32.findall(error)), error


class Stack:
    """`gaitmend serve` plus N `gaitmend worker`s on one deployment (a 5 s lease as in
    issue 27). `serve_worker`: serve runs its own embedded worker (the default mode)."""

    def __init__(self, tmp_path: Path, workers: int = 2, serve_worker: bool = False, database_url: str | None = None,
                 broker: tuple[str, str] | None = None, data_dir: Path | None = None, **overrides):
        self.tmp = tmp_path
        overrides = {"lease_s": 5, "redispatch_after_s": 5, "stall_after_s": 8} | overrides
        self.env = deployment(tmp_path, database_url=database_url, broker=broker, **overrides) | EXTRA | {
            "PYTHONPATH": os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), KINDS_DIR) if p)}
        if data_dir is not None:
            self.env["GAITMEND_DATA_DIR"] = str(data_dir)
        self.settings = settings_of({k: v for k, v in self.env.items() if k.startswith("GAITMEND_")
                                     and k != "GAITMEND_EXTRA_KINDS"})
        from app.store.migrate import upgrade

        upgrade(self.settings.db_url)
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.workers: list[Proc] = []
        args = ["serve", "--port", str(self.port)] + ([] if serve_worker else ["--no-worker"])
        self.serve = Proc(args, self.env, tmp_path / "serve.log")
        self.client = httpx.Client(base_url=self.base, timeout=30)
        try:
            for _ in range(workers):  # the schema is migrated above: they start beside serve
                self.start_worker()
            wait_for(self._up, 90, "the server", proc=self.serve)
        except BaseException:
            self.close()
            raise

    def _up(self) -> bool:
        try:
            return self.client.get("/api/health").status_code == 200
        except httpx.HTTPError:
            assert self.serve.p.poll() is None, f"serve exited:\n{self.serve.tail()}"
            return False

    def start_worker(self, **overrides) -> Proc:
        env = self.env | {f"GAITMEND_{k.upper()}": str(v) for k, v in overrides.items()}
        p = Proc(["worker", "--loglevel", "INFO"], env, self.tmp / f"worker{len(self.workers)}.log")
        self.workers.append(p)
        return p

    def wait_ready(self, p: Proc, timeout: float = 60) -> None:
        wait_for(lambda: "ready." in p.log.read_text(errors="replace"), timeout, "the worker", proc=p)

    def submit(self, spec: dict, timeout: float = 60) -> str:
        """POST the spec; a 503 (the store away) is retried after its Retry-After."""
        end = time.monotonic() + timeout
        while True:
            r = self.client.post("/api/jobs", json=spec)
            if r.status_code == 201:
                return r.json()["id"]
            assert r.status_code == 503 and time.monotonic() < end, r.text
            time.sleep(float(r.headers.get("retry-after", 1)))

    def rows(self, ids: list[str] | None = None) -> dict[str, Job]:
        with session_scope(self.settings.db_url, readonly=True) as s:
            q = select(Job)
            if ids is not None:
                q = q.where(Job.id.in_(ids))
            return {j.id: j for j in s.scalars(q)}

    def row(self, jid: str) -> Job:
        return self.rows([jid])[jid]

    def wait_final(self, ids: list[str], timeout: float) -> dict[str, Job]:
        def done():
            rows = self.rows(ids)
            return len(rows) == len(ids) and all(j.status in FINAL for j in rows.values()) and rows

        return wait_for(done, timeout, f"{len(ids)} jobs to finish", interval=0.2, proc=self.serve)

    def claims(self, jid: str) -> int:
        """How many times workers logged a claim of this job."""
        logs = [p.log for p in self.workers] + [self.serve.log]
        return sum(p.read_text(errors="replace").count(f"job {jid} attempt") for p in logs if p.exists())

    def check_results(self, specs: dict[str, dict]) -> None:
        """Every job succeeded with the undisturbed run's numbers, once, with one bundle."""
        rows = self.rows(list(specs))
        for jid, spec in specs.items():
            j = rows[jid]
            assert j.status == "succeeded", (jid, j.status, j.error)
            assert comparable(j.summary) == reference(spec), jid
            assert j.bundle_path and Path(j.bundle_path).is_file(), jid
        bundles = {p.name for p in Path(self.settings.bundle_dir).glob("*.zip")}
        assert {f"{jid}.zip" for jid in specs} <= bundles
        assert not list(Path(self.settings.bundle_dir).glob("*.part")), "a half-written bundle was left"

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.client.close()
        for p in self.workers:
            p.kill9()
            p.stop()
        self.serve.kill9()
        self.serve.stop()


def sigterm_main(p: Proc) -> None:
    """What `docker stop` does: SIGTERM to the worker's main process only."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(p.pid, signal.SIGTERM)


def pg_terminate(base_url: str, app_name: str) -> int:
    """Terminate every backend of this application name; returns how many."""
    import psycopg

    with psycopg.connect(base_url, autocommit=True) as c:
        return c.execute("SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity WHERE application_name = %s "
                         "AND pid <> pg_backend_pid()", (app_name,)).fetchone()[0]


def new_name(prefix: str) -> str:
    return f"{prefix}{uuid.uuid4().hex[:10]}"


def can_mount_tmpfs() -> bool:
    return os.geteuid() == 0 and shutil.which("mount") is not None


class TcpGate:
    """A TCP relay in front of a server (here PostgreSQL) that can be cut: cut() closes
    every relayed connection and refuses new ones until open(). What a client sees is a
    real dropped connection and then a refused one, at a moment the test chooses."""

    def __init__(self, host: str, port: int):
        import socket

        self.target, self.conns, self.is_open, self.lock = (host, port), [], True, threading.Lock()
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        import socket

        while True:
            try:
                client, _ = self.server.accept()
            except OSError:
                return
            with self.lock:
                if not self.is_open:
                    client.close()
                    continue
                upstream = socket.create_connection(self.target)
                self.conns += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(a, b), daemon=True).start()

    @staticmethod
    def _pipe(src, dst) -> None:
        with contextlib.suppress(OSError):
            while data := src.recv(65536):
                dst.sendall(data)
        for s in (src, dst):
            with contextlib.suppress(OSError):
                s.shutdown(2)

    def cut(self) -> None:
        with self.lock:
            self.is_open = False
            for s in self.conns:
                with contextlib.suppress(OSError):
                    s.shutdown(2)
                s.close()
            self.conns = []

    def open(self) -> None:
        with self.lock:
            self.is_open = True

    def close(self) -> None:
        self.cut()
        self.server.close()

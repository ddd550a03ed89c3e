"""Engine and session scope. One engine per (URL, process): a forked worker child never
reuses its parent's connections."""

from __future__ import annotations

import collections
import contextlib
import json
import math
import os
import threading
from collections.abc import Iterator

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.orm import Session, sessionmaker


class FifoLock:
    """A lock handed to waiters in arrival order (threading.Lock lets a newcomer overtake
    a woken waiter that is still waiting for the GIL, which stretches the latency tail)."""

    def __init__(self):
        self._mutex = threading.Lock()
        self._waiters: collections.deque[threading.Lock] = collections.deque()
        self._held = False

    def __enter__(self):
        with self._mutex:
            if not self._held:
                self._held = True
                return self
            gate = threading.Lock()
            gate.acquire()
            self._waiters.append(gate)
        gate.acquire()  # released by the holder: ownership passes directly to us
        return self

    def __exit__(self, *exc):
        with self._mutex:
            if self._waiters:
                self._waiters.popleft().release()
            else:
                self._held = False
        return False


def finite_json(value) -> str:
    """JSON for a column: NaN and +-Infinity become null. They are not JSON: SQLite would
    keep text that no JSON reader accepts and PostgreSQL refuses the row. Specs never hold
    them (strict models); a metric a kind could not compute is stored as null."""
    return json.dumps(_finite(value), allow_nan=False)


def _finite(v):
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    return v


def read_json(text: str):
    """Rows written before finite_json may hold NaN: read them as null, never a 500."""
    return json.loads(text, parse_constant=lambda _c: None)


_lock = threading.Lock()
_engines: dict[tuple[str, int], tuple[Engine, sessionmaker]] = {}
# SQLite has one writer at a time. Threads of one process queue on this lock, in order,
# instead of polling in SQLite's busy handler (which sleeps up to 100 ms a try and lets
# newcomers overtake). Other processes still meet the busy timeout, but they write
# rarely (a few rows per generation).
_sqlite_writers: dict[str, FifoLock] = {}

SQLITE_BUSY_TIMEOUT_MS = 30_000
SQLITE_WAL_LIMIT_BYTES = 16 * 1024 * 1024


def _sqlite_engine(url: str) -> Engine:
    path = url.removeprefix("sqlite:///")
    if path and path != ":memory:":
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    engine = create_engine(url, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_MS / 1000, "check_same_thread": False},
                           json_serializer=finite_json, json_deserializer=read_json)

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn, _rec):
        # We issue BEGIN ourselves (below); the driver's implicit transactions would
        # start a deferred one that can fail with SQLITE_BUSY when it turns into a write.
        dbapi_conn.isolation_level = None
        cur = dbapi_conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
        cur.execute("PRAGMA synchronous=NORMAL")
        # After each checkpoint the write-ahead log is cut back to this size (it only ever
        # grew before); the housekeeper's sweep truncates it to zero (app/store/space.py).
        cur.execute(f"PRAGMA journal_size_limit={SQLITE_WAL_LIMIT_BYTES}")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn):
        # Writers take the lock up front, so the busy timeout applies and the
        # transaction never has to be upgraded; readers use a WAL snapshot.
        conn.exec_driver_sql("BEGIN" if conn.get_execution_options().get("readonly") else "BEGIN IMMEDIATE")

    return engine


def get_engine(url: str) -> tuple[Engine, sessionmaker]:
    key = (url, os.getpid())
    with _lock:
        if key not in _engines:
            if url.startswith("sqlite"):
                engine = _sqlite_engine(url)
            else:
                engine = create_engine(url, pool_pre_ping=True, pool_size=10, max_overflow=20,
                                       json_serializer=finite_json, json_deserializer=read_json)
            _engines[key] = (engine, sessionmaker(engine, expire_on_commit=False))
        return _engines[key]


def forget_engines() -> None:
    """After a fork: drop (without closing) connections inherited from the parent."""
    with _lock:
        for (url, pid), (engine, _) in list(_engines.items()):
            if pid != os.getpid():
                engine.dispose(close=False)
                del _engines[(url, pid)]


def _after_fork_in_child() -> None:
    # A lock held by another thread of the parent at fork time stays held forever in
    # the child: start the child with fresh ones.
    global _lock
    _lock = threading.Lock()
    _sqlite_writers.clear()
    forget_engines()


os.register_at_fork(after_in_child=_after_fork_in_child)


@contextlib.contextmanager
def session_scope(url: str, readonly: bool = False) -> Iterator[Session]:
    """One short transaction: commits on success, rolls back on error."""
    _, factory = get_engine(url)
    guard = contextlib.nullcontext()
    if not readonly and url.startswith("sqlite"):
        with _lock:
            guard = _sqlite_writers.setdefault(url, FifoLock())
    with guard, factory() as session:
        if readonly:
            session.connection(execution_options={"readonly": True})
        try:
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise

"""Which failures of the store are transient, what a user may read of one, and retrying.

A dropped database connection (a failover, a restart, a pooler, `pg_terminate_backend`),
a database that is starting up, SQLite's busy timeout, and a full disk are not the job's
fault: the caller retries them (the job's lease still fences a stale writer), or the API
answers 503 with Retry-After. Everything else (a constraint, bad data, a bug) is not
retried. No message made here contains SQL, its parameters or a lease token: SQLAlchemy's
text of an error carries all three.
"""

from __future__ import annotations

import errno
import logging
import re
import time
from collections.abc import Callable
from typing import Literal, TypeVar

T = TypeVar("T")
log = logging.getLogger("gaitmend.store")

Transient = Literal["connection", "space"]

# PostgreSQL SQLSTATE classes and codes that a retry can outlive: 08 connection exceptions,
# 57P01-57P03 admin/crash shutdown and "cannot connect now", 53 insufficient resources
# (53100 disk full is "space"), 40001/40P01 serialization failure and deadlock.
_PG_SPACE = {"53100"}
_PG_RETRY_PREFIXES = ("08", "57P", "53", "40001", "40P01")
# SQLite: the busy timeout ran out, the file could not be opened (its folder's disk full
# or away), and SQLITE_FULL.
_SQLITE_RETRY = ("database is locked", "unable to open database file", "disk i/o error")
_SQLITE_SPACE = ("database or disk is full",)
_SPACE_ERRNOS = {errno.ENOSPC, errno.EDQUOT}


class StoreUnavailable(Exception):
    """The database could not be reached (or written for lack of space) for longer than the
    caller could wait. Not the job's fault: the job is handed back, not failed."""


def _chain(exc: BaseException):
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        yield exc
        exc = getattr(exc, "orig", None) or exc.__cause__ or exc.__context__


def transient(exc: BaseException) -> Transient | None:
    """"connection" for an error a retry can outlive, "space" for a full disk, else None."""
    from sqlalchemy import exc as sa_exc

    for e in _chain(exc):
        if isinstance(e, OSError) and e.errno in _SPACE_ERRNOS:
            return "space"
        if isinstance(e, StoreUnavailable):
            return "connection"
        code = (getattr(e, "sqlstate", None) or getattr(e, "pgcode", None)
                or getattr(getattr(e, "diag", None), "sqlstate", None))
        if isinstance(code, str) and code:
            if code in _PG_SPACE:
                return "space"
            if code.startswith(_PG_RETRY_PREFIXES):
                return "connection"
        if isinstance(e, sa_exc.DBAPIError) and e.connection_invalidated:
            return "connection"
        if isinstance(e, sa_exc.TimeoutError):  # the connection pool was exhausted for its timeout
            return "connection"
        name = type(e).__module__ + "." + type(e).__name__
        text = str(e).lower()
        if name.startswith("sqlite3."):
            if any(t in text for t in _SQLITE_SPACE):
                return "space"
            if any(t in text for t in _SQLITE_RETRY):
                return "connection"
        if name.startswith("psycopg") and type(e).__name__ in ("OperationalError", "InterfaceError"):
            # No SQLSTATE: the client lost the server (closed socket, refused connection).
            return "connection"
        if isinstance(e, (sa_exc.InterfaceError,)) and "closed" in text:
            return "connection"
    return None


_HEX32 = re.compile(r"\b[0-9a-f]{32}\b")


def safe_message(exc: BaseException, keep: set[str] | frozenset[str] = frozenset()) -> str:
    """`Type: first line of the message` without SQL, parameters or 32-hex tokens (lease
    tokens, API token hashes), except the strings in `keep` (e.g. the job's own id). For a
    database error the driver's own message is used, never SQLAlchemy's text around it."""
    from sqlalchemy import exc as sa_exc

    inner = exc.orig if isinstance(exc, sa_exc.StatementError) and exc.orig is not None else exc
    text = str(inner)
    for marker in ("\n[SQL:", "[SQL:", "\n[parameters:", "(Background on this error"):
        text = text.split(marker, 1)[0]
    text = text.strip().splitlines()[0] if text.strip() else ""
    text = _HEX32.sub(lambda m: m.group(0) if m.group(0) in keep else "<redacted>", text)
    if len(text) > 500:
        text = text[:500] + "..."
    name = type(inner).__name__
    return f"{name}: {text}" if text else name


def retry(fn: Callable[[], T], *, until: float, what: str, first_delay: float = 0.05,
          max_delay: float = 2.0, space_until: float | None = None,
          should_stop: Callable[[], bool] | None = None) -> T:
    """fn() again after a transient error (backoff from first_delay to max_delay) until
    time.monotonic() passes `until` (`space_until` for a full disk, default the same),
    or `should_stop()`; then StoreUnavailable, chained to the last error. Other errors
    are raised at once."""
    delay, tries = first_delay, 0
    while True:
        try:
            return fn()
        except Exception as e:  # noqa: BLE001  (classified below)
            kind = transient(e)
            if kind is None:
                raise
            tries += 1
            now = time.monotonic()
            end = space_until if (kind == "space" and space_until is not None) else until
            if now >= end or (should_stop is not None and should_stop()):
                raise StoreUnavailable(f"{what}: {'no space left' if kind == 'space' else 'the database was unavailable'}"
                                       f" ({tries} tries; {safe_message(e)})") from e
            if tries == 1 or tries % 10 == 0:
                log.warning("%s: %s (%s); retrying", what, "no space left" if kind == "space" else "database unavailable",
                            safe_message(e))
            time.sleep(max(min(delay, end - now), 0.0))
            delay = min(delay * 2, max_delay)


def unavailable(exc: BaseException, where: str | None = None) -> tuple[str, int] | None:
    """(message, Retry-After seconds) for an API answer of 503 when `exc` is a database or
    storage failure a client can wait out, else None. `where`: the data folder and its free
    space (app/store/space.py describe), named in a full disk's message. No SQL in it."""
    kind = transient(exc)
    if kind is None:
        return None
    if kind == "space":
        return (f"no space left on the disk{f' of the data folder {where}' if where else ''}; jobs can still be "
                f"deleted to free space ({safe_message(exc)})", 30)
    return f"the database is unavailable; retry shortly ({safe_message(exc)})", 2


def with_retries(fn: Callable[[], T], retry_s: float, what: str) -> T:
    """fn() retried on a dropped connection for up to `retry_s` (not on a full disk: that
    is not outlived in seconds). For reads and idempotent writes of the API."""
    until = time.monotonic() + retry_s
    return retry(fn, until=until, space_until=time.monotonic(), what=what, max_delay=0.5)

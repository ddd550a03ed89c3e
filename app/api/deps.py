"""What every route of the API shares: the app's settings and ONE database dependency.

A route declares ``db: Db = Depends(get_db)`` and calls ``await db.read(fn)`` (or
``db.write``): ``fn(session)`` runs in the thread pool inside one short transaction of
app/store/db.py's ``session_scope``, and the store's NotFound and Conflict become the
API's 404 and 409. Code that already runs in a worker thread (several transactions in
one trip, e.g. commit a job, then send its id) opens them with ``db.session()``.

A read that meets a dropped database connection is tried again for up to
GAITMEND_DB_RETRY_S; what is still failing becomes a JSON 503 with Retry-After
(app/api/errors.py, app/store/errors.py).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import TypeVar

from fastapi import Request
from fastapi.concurrency import run_in_threadpool
from sqlalchemy.orm import Session

from app.api.errors import ApiError
from app.core.settings import Settings
from app.store import repo
from app.store.db import session_scope
from app.store.errors import with_retries

T = TypeVar("T")


def settings_of(request: Request) -> Settings:
    """The settings create_app() was given."""
    return request.app.state.settings


class Db:
    """The database of the app serving a request."""

    def __init__(self, url: str, retry_s: float = 0.0):
        self.url, self.retry_s = url, retry_s

    @contextlib.contextmanager
    def session(self, readonly: bool = False) -> Iterator[Session]:
        """One short transaction, for code already in a worker thread."""
        with session_scope(self.url, readonly=readonly) as s:
            yield s

    async def run(self, fn: Callable[[Session], T], readonly: bool = False, missing: str = "job") -> T:
        """``fn(session)`` in the thread pool, in one transaction. NotFound is a 404 that
        says which ``missing`` thing ("job", "study") was not found; Conflict a 409."""
        def call():
            with self.session(readonly=readonly) as s:
                return fn(s)

        if readonly and self.retry_s > 0:  # a read may be tried again; a write's commit may have happened
            return await self.call(lambda: with_retries(call, self.retry_s, "API read"), missing)
        return await self.call(call, missing)

    async def call(self, fn: Callable[[], T], missing: str = "job") -> T:
        """``fn()`` in the thread pool, with ``run``'s 404 and 409 (for code that opens its
        own transactions, e.g. app/store/space.py delete_job)."""
        try:
            return await run_in_threadpool(fn)
        except repo.NotFound as e:
            raise ApiError(404, f"no {missing} {str(e)!r}", field="id") from None
        except repo.Conflict as e:  # e.g. an id prefix shared by several jobs
            raise ApiError(409, str(e), field=e.field) from None

    async def read(self, fn: Callable[[Session], T], missing: str = "job") -> T:
        """``run`` in a read-only transaction (a WAL snapshot on SQLite: no writer lock)."""
        return await self.run(fn, readonly=True, missing=missing)

    async def write(self, fn: Callable[[Session], T], missing: str = "job") -> T:
        return await self.run(fn, readonly=False, missing=missing)


async def get_db(request: Request) -> Db:
    """The dependency: ``db: Db = Depends(get_db)`` (async: FastAPI would run a plain
    function in the thread pool, one hop more per request)."""
    return db_of(request)


def db_of(request: Request) -> Db:
    """The same for code that is handed the request itself (auth, the health check)."""
    settings = settings_of(request)
    return Db(settings.db_url, settings.db_retry_s)


"""Apply and inspect the Alembic migrations in migrations/ (next to the app package, or
inside it in a wheel: app/core/assets.py)."""

from __future__ import annotations

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory

from app.core.assets import asset_dir
from app.store.db import get_engine

MIGRATIONS = asset_dir("migrations")


def alembic_config(url: str) -> Config:
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return cfg


def upgrade(url: str, revision: str = "head") -> None:
    command.upgrade(alembic_config(url), revision)


def downgrade(url: str, revision: str) -> None:
    command.downgrade(alembic_config(url), revision)


def head(url: str) -> str:
    return ScriptDirectory.from_config(alembic_config(url)).get_current_head()


def current(url: str) -> str | None:
    engine, _ = get_engine(url)
    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision()


def at_head(url: str) -> bool:
    return current(url) == head(url)


class SchemaError(RuntimeError):
    """The database is reachable but not at gaitmend's schema, and migrating it failed."""


def ensure_schema(url: str) -> str | None:
    """An API started on its own (``uvicorn --factory app.api:create_app``, not `gaitmend
    serve`) migrates its database at start-up, as serve does, instead of answering 500 "no
    such table" until something does. Returns what it did in words (None: already at head,
    or out of reach, which the API answers as 503 per request); raises SchemaError, saying
    how to fix it, when the migration fails."""
    try:
        now, want = current(url), head(url)
    except Exception:  # noqa: BLE001  (unreachable now: every request answers 503 until it is back)
        return None
    if now == want:
        return None
    try:
        upgrade(url)
    except Exception as e:  # noqa: BLE001
        raise SchemaError(f"the database {url.split('@')[-1]} is at schema revision {now or 'none (no tables)'}, not "
                          f"{want}, and migrating it failed ({type(e).__name__}: {e}); run `gaitmend db upgrade` "
                          "with the same GAITMEND_DATABASE_URL / GAITMEND_DATA_DIR (`gaitmend serve` does it)") from e
    return f"migrated the database from revision {now or 'none (no tables)'} to {want}"

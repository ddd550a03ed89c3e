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

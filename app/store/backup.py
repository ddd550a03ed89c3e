"""A consistent copy of the database while the server runs (`gaitmend db backup PATH`).

Copying gaitmend.db alone misses what is still in its write-ahead log (gaitmend.db-wal);
SQLite's online backup API copies the committed state, WAL included, page by page without
stopping writers. PostgreSQL has its own tool for this: pg_dump.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

from sqlalchemy.engine import make_url


class BackupError(ValueError):
    pass


def sqlite_path(db_url: str) -> Path | None:
    url = make_url(db_url)
    if url.get_backend_name() != "sqlite":
        return None
    return Path(url.database or "")


def pg_dump_hint(db_url: str) -> str:
    url = make_url(db_url).set(drivername="postgresql")
    return f"pg_dump --format=custom --file=PATH '{url.render_as_string(hide_password=True)}'"


def backup(db_url: str, dest: Path, overwrite: bool = False) -> dict:
    """Copy a SQLite database to `dest` (a new file); returns {"source", "dest", "bytes", "jobs"}."""
    src = sqlite_path(db_url)
    if src is None:
        raise BackupError(f"the database is PostgreSQL; back it up with {pg_dump_hint(db_url)}")
    if not src.is_file():
        raise BackupError(f"no database at {src} (GAITMEND_DATA_DIR / GAITMEND_DATABASE_URL)")
    dest = Path(dest)
    if dest.resolve() == src.resolve():
        raise BackupError("the backup must go to another file than the database itself")
    if dest.exists() and not overwrite:
        raise BackupError(f"{dest} exists; pass --force to replace it")
    if not dest.parent.is_dir():
        raise BackupError(f"no folder {dest.parent}")
    tmp = dest.with_name(dest.name + ".partial")
    tmp.unlink(missing_ok=True)
    source = sqlite3.connect(f"file:{src}?mode=ro", uri=True, timeout=30)
    try:
        target = sqlite3.connect(tmp)
        try:
            source.backup(target)
            target.execute("PRAGMA journal_mode=DELETE")  # one self-contained file
            try:
                jobs = target.execute("SELECT count(*) FROM jobs").fetchone()[0]
            except sqlite3.OperationalError:  # not migrated yet
                jobs = None
        finally:
            target.close()
    finally:
        source.close()
    tmp.replace(dest)  # nothing half-written at PATH
    return {"source": str(src), "dest": str(dest), "bytes": dest.stat().st_size, "jobs": jobs}

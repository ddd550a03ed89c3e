"""Disk space of the data folder: what is free, a reserve to give up when the disk is
full, and the housekeeping that keeps the folder from growing without bounds (the SQLite
write-ahead log, bundles and checkpoints past their retention, leftovers).

The reserve: a file of GAITMEND_SPACE_RESERVE_MB in the data folder. When the disk is
full, deleting a job (the way a user frees space) may itself need a little space (SQLite
appends to its write-ahead log before it can shrink anything); the delete gives up the
reserve and tries again. The housekeeper puts the reserve back once there is room.
"""

from __future__ import annotations

import datetime as dt
import logging
import os
import shutil
import time
from pathlib import Path

log = logging.getLogger("gaitmend.space")

RESERVE = ".space-reserve"


def free_bytes(folder: Path) -> int | None:
    """Free bytes on the file system of `folder` (its nearest existing parent), or None."""
    p = Path(folder).resolve()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return shutil.disk_usage(p).free
    except OSError:
        return None


def describe(folder: Path) -> str:
    """'<folder> (<free> free)' for a message about a full disk."""
    free = free_bytes(folder)
    return f"{Path(folder).resolve()} ({'unknown' if free is None else human(free)} free)"


def human(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n} B"


def reserve_path(data_dir: Path) -> Path:
    return Path(data_dir) / RESERVE


def ensure_reserve(data_dir: Path, mb: int) -> bool:
    """Create the reserve file when it is missing and there is room for it and as much
    again. Returns whether the reserve is in place."""
    path = reserve_path(data_dir)
    size = mb * 1024 * 1024
    if size <= 0:
        path.unlink(missing_ok=True)
        return False
    try:
        if path.is_file() and path.stat().st_size == size:
            return True
        free = free_bytes(data_dir)
        if free is None or free < 2 * size:
            return False
        part = path.with_suffix(".part")
        with open(part, "wb") as f:
            try:
                os.posix_fallocate(f.fileno(), 0, size)
            except (AttributeError, OSError):  # no fallocate here: write it out
                f.truncate(0)
                block = b"\0" * (1024 * 1024)
                for _ in range(mb):
                    f.write(block)
            f.flush()
        os.replace(part, path)
        return True
    except OSError as e:
        log.warning("could not put the space reserve in %s: %s", data_dir, e)
        path.with_suffix(".part").unlink(missing_ok=True)
        return False


def release_reserve(data_dir: Path) -> bool:
    """Give the reserve up (the disk is full and something must be written)."""
    path = reserve_path(data_dir)
    try:
        path.unlink()
    except FileNotFoundError:
        return False
    log.warning("the disk of %s is full: gave up the %s reserve so that jobs can be deleted", data_dir, RESERVE)
    return True


def checkpoint_wal(db_url: str) -> None:
    """SQLite: copy the write-ahead log into the database and truncate it to zero bytes
    (without this it only ever grows: 4 MB after 200 tiny jobs). Busy readers or writers
    make the truncation wait for a later pass; that is fine."""
    if not db_url.startswith("sqlite"):
        return
    from app.store.db import get_engine

    engine, _ = get_engine(db_url)
    raw = engine.raw_connection()  # outside any transaction (a checkpoint inside one cannot truncate)
    try:
        cur = raw.cursor()
        busy, _log, _done = cur.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()
        cur.close()
        if busy:
            log.debug("WAL checkpoint of %s: busy, truncation left to a later pass", db_url)
    finally:
        raw.close()


def sweep(settings) -> dict[str, int]:
    """Retention and leftovers (idempotent; several housekeepers may run it at once):
    bundles and checkpoints past their retention, half-written bundle files of killed
    workers, empty artifact folders; the SQLite log; the reserve. Returns counts."""
    from app.store import repo
    from app.store.db import session_scope
    from app.store.models import utcnow

    out = {"bundles": 0, "checkpoints": 0, "parts": 0, "folders": 0}
    now = utcnow()
    if settings.bundle_retention_days > 0:
        before = now - dt.timedelta(days=settings.bundle_retention_days)
        with session_scope(settings.db_url, readonly=True) as s:
            expired = repo.expired_bundles(s, before)
        for job_id, path in expired:
            Path(path).unlink(missing_ok=True)
        if expired:
            with session_scope(settings.db_url) as s:
                repo.forget_bundles(s, [j for j, _ in expired])
            out["bundles"] = len(expired)
    if settings.checkpoint_retention_days > 0:
        with session_scope(settings.db_url) as s:
            out["checkpoints"] = repo.drop_checkpoints(s, now - dt.timedelta(days=settings.checkpoint_retention_days))
    cutoff = time.time() - 3600  # a bundle is written in seconds: an hour-old part file is a leftover
    for folder in (Path(settings.bundle_dir), Path(settings.data_dir)):
        if folder.is_dir():
            for p in folder.glob("*.part"):
                try:
                    if p.stat().st_mtime < cutoff:
                        p.unlink()
                        out["parts"] += 1
                except OSError:
                    pass
    art = Path(settings.artifact_dir)
    if art.is_dir():
        with session_scope(settings.db_url, readonly=True) as s:
            running = set(repo.running_ids(s))
        for p in art.iterdir():
            try:
                if p.name not in running and p.is_dir() and not any(p.iterdir()) and p.stat().st_mtime < cutoff:
                    p.rmdir()
                    out["folders"] += 1
            except OSError:
                pass
    try:
        checkpoint_wal(settings.db_url)
    except Exception as e:  # noqa: BLE001  (busy or full: a later pass tries again)
        log.debug("WAL checkpoint skipped: %s", e)
    ensure_reserve(settings.data_dir, settings.space_reserve_mb)
    if any(out.values()):
        log.info("retention and leftovers: %s", out)
    return out


def delete_job(settings, job_id: str, owner: str | None):
    """Delete a job that is not running with its history, checkpoint, bundle and artifact
    folder, also on a full disk: the bundle goes first (its space is what the database needs
    to record the delete), and if the database still cannot write, the reserve is given up
    and the delete tried again. NotFound and Conflict as repo.delete_job."""
    from app.store import repo
    from app.store.db import session_scope
    from app.store.errors import transient

    with session_scope(settings.db_url, readonly=True) as s:
        job = repo.get_job(s, job_id, owner)
        if job.status == "running":
            raise repo.Conflict("the job is running; cancel it first", field="status")
        full_id, bundle = job.id, job.bundle_path
    if bundle:
        Path(bundle).unlink(missing_ok=True)

    def once():
        with session_scope(settings.db_url) as s:
            return repo.delete_job(s, full_id, owner)

    try:
        job = once()
    except Exception as e:
        if transient(e) != "space" or not release_reserve(settings.data_dir):
            raise
        job = once()
    shutil.rmtree(Path(settings.artifact_dir) / full_id, ignore_errors=True)
    return job

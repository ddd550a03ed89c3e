"""The robots table (issue 23): uploaded robots, owned like jobs, immutable once stored.
Its files (the sanitised model and its assets) live under <data_dir>/robots/<id>/; a
changed model is a new robot with a new content hash. Imported by app/store/__init__.py so
that the one metadata (and Alembic's comparison with the migrations) includes it."""

from __future__ import annotations

import datetime as dt
from typing import Any

from sqlalchemy import Index, Integer, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from app.store.models import Base, utcnow


class RobotRow(Base):
    __tablename__ = "robots"

    seq: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    id: Mapped[str] = mapped_column(String(32), unique=True)  # public id, what a job names
    owner: Mapped[str] = mapped_column(String(64))
    content_hash: Mapped[str] = mapped_column(String(64))  # sha256 of model, assets and leg map
    name: Mapped[str] = mapped_column(String(200))
    legs: Mapped[dict[str, Any]] = mapped_column()  # the leg map (app/robots/legmap.py)
    info: Mapped[dict[str, Any]] = mapped_column()  # sizes, leg points, files, whether the legs were detected
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    __table_args__ = (
        UniqueConstraint("owner", "content_hash", name="uq_robots_owner_content_hash"),
        Index("ix_robots_owner_seq", "owner", "seq"),
    )

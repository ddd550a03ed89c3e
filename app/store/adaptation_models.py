"""The adaptation tables (issue 44): a session over one or more finished repertoire jobs,
owned like a job, and its measured trials, one row each. The rows are the session's whole
state: the model, the next proposal and the stop decision are recomputed from them
(app/adapt/session.py), so a restart of the service loses nothing. Imported by
app/store/__init__.py so that the one metadata (and Alembic's comparison with the
migrations) includes them."""

from __future__ import annotations

import datetime as dt
from typing import Any

from sqlalchemy import Boolean, Float, ForeignKey, Index, Integer, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from app.store.models import Base, utcnow


class AdaptationRow(Base):
    __tablename__ = "adaptations"

    seq: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    id: Mapped[str] = mapped_column(String(32), unique=True)  # public id
    owner: Mapped[str] = mapped_column(String(64))
    spec: Mapped[dict[str, Any]] = mapped_column()  # app/adapt/session.py SessionSpec, every default filled in
    status: Mapped[str] = mapped_column(String(16), default="open")  # open | finished
    stop_reason: Mapped[str | None] = mapped_column(Text)
    trials: Mapped[int] = mapped_column(Integer, default=0)  # rows in adaptation_trials
    # the recovery target (m/s) of the maps' robot, fixed when the session is created (an uploaded robot's is
    # measured on its stored model then); null: a session created before the column, whose built-in robot's target
    # is looked up as before (app/adapt/session.py target_m_s)
    target_m_s: Mapped[float | None] = mapped_column(Float, nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    __table_args__ = (Index("ix_adaptations_owner_seq", "owner", "seq"),)


class AdaptationTrial(Base):
    """Trial ``index`` (1-based) of a session: the gait proposed for it and what the lab measured."""

    __tablename__ = "adaptation_trials"

    adaptation_seq: Mapped[int] = mapped_column(ForeignKey("adaptations.seq", ondelete="CASCADE"), primary_key=True)
    index: Mapped[int] = mapped_column(Integer, primary_key=True)
    map: Mapped[str] = mapped_column(String(200))
    elite: Mapped[int] = mapped_column(Integer)
    forward_m: Mapped[float] = mapped_column(Float)
    lateral_m: Mapped[float] = mapped_column(Float)
    yaw_deg: Mapped[float] = mapped_column(Float)
    fell: Mapped[bool] = mapped_column(Boolean)
    duration_s: Mapped[float] = mapped_column(Float)
    note: Mapped[str] = mapped_column(Text, default="")
    proposal: Mapped[dict[str, Any]] = mapped_column()  # the proposal as returned before the trial
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

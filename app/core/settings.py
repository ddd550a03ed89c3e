"""The one Settings object of the job service. Every value comes from a GAITMEND_* variable
(or its default); a bad value stops the process at start-up with the variable's name."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Literal

from pydantic import Field, ValidationError, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

EMBEDDED = "embedded"


class SettingsError(ValueError):
    pass


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="GAITMEND_", extra="ignore", validate_default=True, frozen=True)

    data_dir: Path = Path("./gaitmend-data")
    # Default: a SQLite file under data_dir. PostgreSQL: postgresql://user@host/db.
    database_url: str = ""
    # "embedded": Celery's filesystem transport under data_dir/broker (no server);
    # or redis://host:port/db.
    broker_url: str = EMBEDDED
    # Passwords given apart from the URLs (docker-compose.yml does): any characters, '@' and
    # '/' included; they are percent-encoded into the URLs here, never pasted raw.
    database_password: str = Field("", repr=False)
    broker_password: str = Field("", repr=False)
    queue: str = Field("gaitmend", pattern=r"^[A-Za-z0-9_.-]{1,64}$")
    # Prefix for every Redis key Celery writes, so several deployments can share one Redis.
    redis_key_prefix: str = Field("gaitmend:", max_length=64)

    # Limits (API).
    max_body_bytes: int = Field(64 * 1024, ge=1024, le=16 * 1024 * 1024)
    max_evaluations_per_job: int = Field(200_000, ge=1)
    max_queued_per_owner: int = Field(100, ge=1)
    auth: Literal["auto", "on", "off"] = "auto"  # auto: required unless bound to loopback

    # Reliability (workers).
    lease_s: float = Field(30.0, ge=1.0, le=3600.0)  # renewed every lease_s / 3 while running
    max_attempts: int = Field(3, ge=1, le=20)  # worker deaths tolerated per job
    reaper_interval_s: float = Field(5.0, gt=0.0, le=600.0)
    # A queued job whose message was sent this long ago and not yet claimed is sent again
    # when a worker slot sits idle or the broker holds fewer messages than such jobs (the
    # message was lost: a killed worker, a broker that lost its data). Claiming twice is
    # harmless. docs/faults.md.
    redispatch_after_s: float = Field(30.0, ge=1.0, le=3600.0)
    max_job_s: int = Field(6 * 3600, ge=10)  # a running job past this fails
    visibility_timeout_s: int = Field(12 * 3600, ge=60)  # Redis redelivery; must exceed max_job_s
    worker_concurrency: int = Field(1, ge=1, le=64)
    # A pool process is replaced after this many jobs, or at once after a job that left it
    # above the memory limit (checked after every job). Replacing one costs ~0.3-5 s (its
    # exit, billiard noticing it, the fork), paid by the next job: every 20 jobs it was
    # most of a tiny study point's dispatch overhead (docs/studies.md).
    worker_max_tasks_per_child: int = Field(500, ge=1)
    worker_max_memory_per_child_mb: int = Field(2048, ge=64, le=1024 * 1024)
    # Rollout threads per job (app/sim/threads.py); unset: the worker sets cores / concurrency.
    sim_threads: int | None = Field(None, ge=1, le=256)
    poll_interval_s: float = Field(0.2, gt=0.0, le=5.0)  # embedded broker polling

    # Faults (docs/faults.md).
    # SIGTERM: a worker stops taking jobs and hands its running job back at the next
    # generation boundary (checkpointed, no attempt spent); one still inside a generation
    # after this long is handed back from its last checkpoint and the process exits.
    # Docker's default stop timeout is 10 s: keep this well under it.
    stop_grace_s: float = Field(5.0, ge=0.0, le=600.0)
    # /api/health is "degraded" when queued jobs have waited this long while worker slots
    # sit idle (or no worker is connected to the broker).
    stall_after_s: float = Field(60.0, ge=1.0, le=86400.0)
    # /api/health is "degraded" below this much free space in the data folder.
    min_free_mb: int = Field(512, ge=0, le=1024 * 1024)
    # A file of this size kept in the data folder and given up when the disk is full, so
    # that deleting jobs (the way to free space) still works; 0: none.
    space_reserve_mb: int = Field(8, ge=0, le=1024)
    # A job whose bundle or checkpoint cannot be written for lack of space waits this long
    # for space (keeping its lease), then fails with a message naming the folder.
    storage_wait_s: float = Field(600.0, ge=0.0, le=7 * 86400.0)
    # Retention: bundles of jobs finished longer ago than this are deleted (0: kept forever);
    # checkpoints of failed or cancelled jobs (what a retry resumes from) are deleted this
    # long after the job finished (a succeeded job's checkpoint goes when it succeeds).
    bundle_retention_days: float = Field(0.0, ge=0.0, le=36500.0)
    checkpoint_retention_days: float = Field(7.0, ge=0.0, le=36500.0)
    # Database writes of a running job that fail on a dropped connection are retried for
    # up to the lease; API requests retry reads for this long before answering 503.
    db_retry_s: float = Field(2.0, ge=0.0, le=60.0)

    # Client side (gaitmend submit / jobs / fetch).
    server: str = "http://127.0.0.1:8000"
    token: str = ""

    @field_validator("broker_url")
    @classmethod
    def _broker(cls, v: str) -> str:
        if v != EMBEDDED and not v.startswith(("redis://", "rediss://")):
            raise ValueError(f"must be {EMBEDDED!r} or a redis:// URL, got {v!r}")
        return v

    @field_validator("database_url")
    @classmethod
    def _db(cls, v: str) -> str:
        if v and not v.startswith(("sqlite:", "postgresql:", "postgresql+psycopg:")):
            raise ValueError(f"must be a sqlite:/// or postgresql:// URL, got {v!r}")
        return v

    @model_validator(mode="after")
    def _consistent(self):
        if self.visibility_timeout_s <= self.max_job_s:
            raise ValueError(f"GAITMEND_VISIBILITY_TIMEOUT_S ({self.visibility_timeout_s}) must exceed "
                             f"GAITMEND_MAX_JOB_S ({self.max_job_s}), or Redis redelivers running jobs")
        return self

    @property
    def embedded_broker(self) -> bool:
        return self.broker_url == EMBEDDED

    @property
    def db_url(self) -> str:
        """SQLAlchemy URL; psycopg 3 is the PostgreSQL driver."""
        url = self.database_url or f"sqlite:///{(self.data_dir / 'gaitmend.db').resolve()}"
        if url.startswith("postgresql://"):
            url = "postgresql+psycopg://" + url[len("postgresql://"):]
        if self.database_password and url.startswith("postgresql"):
            from sqlalchemy.engine import make_url

            url = make_url(url).set(password=self.database_password).render_as_string(hide_password=False)
        return url

    @property
    def broker_connection_url(self) -> str:
        """The broker URL with GAITMEND_BROKER_PASSWORD percent-encoded into it."""
        if not self.broker_password or self.embedded_broker:
            return self.broker_url
        from urllib.parse import quote, urlsplit, urlunsplit

        parts = urlsplit(self.broker_url)
        host = parts.netloc.rsplit("@", 1)[-1]
        user = parts.netloc.rsplit("@", 1)[0].split(":")[0] if "@" in parts.netloc else ""
        return urlunsplit(parts._replace(netloc=f"{user}:{quote(self.broker_password, safe='')}@{host}"))

    @property
    def bundle_dir(self) -> Path:
        return self.data_dir / "bundles"

    @property
    def artifact_dir(self) -> Path:
        return self.data_dir / "artifacts"

    @property
    def broker_dir(self) -> Path:
        return self.data_dir / "broker" / self.queue


def _explain(exc: ValidationError) -> str:
    parts = []
    for e in exc.errors():
        name = "GAITMEND_" + "_".join(str(p) for p in e["loc"]).upper() if e["loc"] else "settings"
        msg = e["msg"].removeprefix("Value error, ")
        parts.append(f"{name}: {msg}" + (f" (got {e['input']!r})" if e["loc"] else ""))
    return "; ".join(parts)


def load_settings(**overrides) -> Settings:
    try:
        return Settings(**overrides)
    except ValidationError as e:
        raise SettingsError(_explain(e)) from None


@functools.lru_cache(maxsize=1)
def get_settings() -> Settings:
    return load_settings()

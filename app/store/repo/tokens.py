"""API tokens: stored as SHA-256 hashes only; a token names its owner."""

from __future__ import annotations

import hashlib
import secrets

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session

from app.store.models import ApiToken, utcnow
from app.store.repo.jobs import Conflict


def hash_token(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def create_token(s: Session, name: str) -> str:
    if s.scalar(select(ApiToken).where(ApiToken.name == name)) is not None:
        raise Conflict(f"a token named {name!r} exists; revoke it first", field="name")
    token = "gm_" + secrets.token_urlsafe(32)
    s.add(ApiToken(name=name, token_hash=hash_token(token)))
    return token


def resolve_token(s: Session, token: str) -> str | None:
    found = resolve_token_id(s, token)
    return found[0] if found else None


def resolve_token_id(s: Session, token: str) -> tuple[str, int] | None:
    """(owner name, token row id) of a live token."""
    row = s.scalar(select(ApiToken).where(ApiToken.token_hash == hash_token(token)))
    if row is None:
        return None
    now = utcnow()
    if row.last_used_at is None or (now - row.last_used_at).total_seconds() > 60:
        row.last_used_at = now  # at most one write a minute per token
    return row.name, row.id


def token_owner(s: Session, token_id: int) -> str | None:
    """The owner of a token that still exists (signed links die with their token)."""
    return s.scalar(select(ApiToken.name).where(ApiToken.id == token_id))


def list_tokens(s: Session) -> list[ApiToken]:
    return list(s.scalars(select(ApiToken).order_by(ApiToken.id)))


def revoke_token(s: Session, name: str) -> bool:
    return s.execute(delete(ApiToken).where(ApiToken.name == name)).rowcount == 1


def token_count(s: Session) -> int:
    return s.scalar(select(func.count()).select_from(ApiToken))

"""Bearer API tokens. Stored as sha256 hashes; required whenever the server is reachable
from other hosts (or GAITMEND_AUTH=on). Without auth everything belongs to "local"."""

from __future__ import annotations

import dataclasses
import ipaddress

from fastapi import Request

from app.api.deps import db_of
from app.api.errors import ApiError
from app.store import repo

LOCAL_OWNER = "local"


@dataclasses.dataclass(frozen=True)
class Principal:
    name: str
    restricted: bool  # False: sees every job (no auth, no token)
    token_id: int | None = None  # the token's row: links signed for it die when it is revoked

    @property
    def owner_filter(self) -> str | None:
        return self.name if self.restricted else None


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def auth_required(mode: str, host: str) -> bool:
    return mode == "on" or (mode == "auto" and not is_loopback(host))


async def principal(request: Request) -> Principal:
    header = request.headers.get("authorization", "")
    required = request.app.state.auth_required
    if not header:
        if required:
            raise ApiError(401, "an API token is required: Authorization: Bearer <token> (gaitmend token create NAME)",
                           field="Authorization", headers={"WWW-Authenticate": "Bearer"})
        return Principal(LOCAL_OWNER, restricted=False)
    scheme, _, token = header.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise ApiError(401, "Authorization must be 'Bearer <token>'", field="Authorization",
                       headers={"WWW-Authenticate": "Bearer"})
    found = await db_of(request).write(lambda s: repo.resolve_token_id(s, token.strip()))
    if found is None:
        raise ApiError(401, "unknown API token", field="Authorization", headers={"WWW-Authenticate": "Bearer"})
    return Principal(found[0], restricted=True, token_id=found[1])

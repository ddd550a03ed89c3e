"""/api/health (/api/robots: app/api/routes/robots.py)."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.concurrency import run_in_threadpool

from app.api.auth import principal
from app.api.deps import Db, get_db, settings_of
from app.api.errors import ApiError
from app.api.schemas import Health, WorkerOut
from app.service.health import assess

router = APIRouter(tags=["service"])


@router.get("/health", response_model=Health, response_model_exclude_none=True)
async def health(request: Request, db: Db = Depends(get_db)):
    """Database, broker, the live workers (consumer connected, seen in the last three
    housekeeping intervals), free space, and why the service is "degraded" when it is
    (app/service/health.py). When tokens are required, only `status` without a valid one."""
    settings = settings_of(request)
    trusted = not request.app.state.auth_required
    if not trusted and request.headers.get("authorization"):
        try:
            trusted = (await principal(request)).restricted
        except ApiError:
            trusted = False

    h = await run_in_threadpool(assess, settings, db.session)
    if not trusted:
        return Health(status=h["status"])
    url = settings.broker_url.split("@")[-1] if "@" in settings.broker_url else settings.broker_url
    return Health(status=h["status"], reasons=h["reasons"], database=h["database"], broker=h["broker"],
                  broker_url=url, workers=[WorkerOut(name=w.name, broker=w.broker, started_at=w.started_at,
                                                     last_seen_at=w.last_seen_at) for w in h["workers"]],
                  disk=h["disk"], queue=h["queue"] or None)

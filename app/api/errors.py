"""Errors as JSON: {"detail": message, "errors": [{"field", "message"}]}, always naming the
field when one is at fault."""

from __future__ import annotations

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.jobs.ranges import RANGE_TYPES, allowed_in_schema, explain


class ApiError(Exception):
    def __init__(self, status: int, message: str, field: str | None = None, errors: list[dict] | None = None,
                 headers: dict | None = None):
        self.status, self.message, self.headers = status, message, headers
        self.errors = errors if errors is not None else ([{"field": field, "message": message}] if field else [])


def error_body(message: str, errors: list[dict]) -> dict:
    return {"detail": message, "errors": errors}


def _loc(loc) -> str:
    parts = [str(p) for p in loc]
    if parts and parts[0] in ("body", "query", "path", "header"):
        parts = parts[1:] or parts
    return ".".join(parts) or "request"


def install(app: FastAPI) -> None:
    _install_store_errors(app)
    @app.exception_handler(ApiError)
    async def _api_error(_req: Request, exc: ApiError):
        return JSONResponse(error_body(exc.message, exc.errors), status_code=exc.status, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(_req: Request, exc: RequestValidationError):
        errors = [{"field": _loc(e["loc"]), "message": _message(_req, e)} for e in exc.errors()]
        return JSONResponse(error_body("; ".join(f"{e['field']}: {e['message']}" for e in errors), errors),
                            status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(req: Request, exc: StarletteHTTPException):
        headers = getattr(exc, "headers", None)
        errors = []
        if exc.status_code == 405:
            # Starlette's Allow names the methods of the first route that matched the path
            # only; GET and POST /api/jobs are two routes. Name every method of the path.
            allowed = _methods_for(req)
            headers = (headers or {}) | {"Allow": ", ".join(allowed)}
            errors = [{"field": "method", "message": f"{req.method} is not allowed here; allowed: {', '.join(allowed)}"}]
        return JSONResponse(error_body(str(exc.detail), errors), status_code=exc.status_code, headers=headers)


def _install_store_errors(app: FastAPI) -> None:
    """A database or storage failure a client can wait out (a dropped connection, a busy
    database, a full disk: app/store/errors.py) is a JSON 503 with Retry-After, never a
    plain-text 500 or a message holding SQL. Any other such error stays a server error."""
    from sqlalchemy.exc import DBAPIError
    from sqlalchemy.exc import TimeoutError as PoolTimeout

    from app.store.errors import StoreUnavailable, unavailable
    from app.store.space import describe

    async def _store(req: Request, exc: Exception):
        found = unavailable(exc, describe(req.app.state.settings.data_dir))
        if found is None:
            raise exc
        message, retry_after = found
        return JSONResponse(error_body(message, [{"field": "service", "message": message}]), status_code=503,
                            headers={"Retry-After": str(retry_after)})

    for cls in (DBAPIError, PoolTimeout, StoreUnavailable, OSError):
        app.add_exception_handler(cls, _store)


def _message(req: Request, e: dict) -> str:
    """A request parameter's error; a range error states the parameter's allowed range, as
    the OpenAPI schema gives it (e.g. limit: "...; allowed: 1 <= limit <= 500")."""
    msg = e["msg"].removeprefix("Value error, ")
    if e.get("type") not in RANGE_TYPES:
        return msg
    loc = tuple(e.get("loc") or ())
    if len(loc) < 2 or loc[0] not in ("query", "path", "header", "cookie"):
        return msg
    try:
        paths = req.app.openapi()["paths"]
    except Exception:  # no schema to read a range from: pydantic's message as it is
        return msg
    # Matched by hand: scope["route"] is the router's own route, whose path lacks the
    # include_router prefix ("/jobs", not "/api/jobs"), so it does not key the OpenAPI paths.
    parts = req.url.path.split("/")
    for template, ops in paths.items():  # "/api/jobs/{job_id}" matches "/api/jobs/abc"
        t = template.split("/")
        if len(t) != len(parts) or any(a != b and not (a.startswith("{") and a.endswith("}")) for a, b in zip(t, parts)):
            continue
        for p in (ops.get(req.method.lower()) or {}).get("parameters", []):
            if p.get("in") == loc[0] and str(p.get("name", "")).lower() == str(loc[1]).lower():
                return explain(msg, allowed_in_schema(p.get("schema") or {}, loc[2:], e["type"], name=p["name"]))
    return msg


HTTP_METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")


def _methods_for(req: Request) -> list[str]:
    """The methods some route answers at the request's path. Asked of every route with each
    method in turn: routes of an included router sit behind one entry of app.router.routes
    (FastAPI includes them lazily), which answers for all of them. Mounts (static files)
    answer any method and are left out."""
    from starlette.routing import Match, Mount

    routes = [r for r in req.app.router.routes if not isinstance(r, Mount)]
    return sorted(m for m in HTTP_METHODS
                  if any(r.matches({**req.scope, "method": m})[0] == Match.FULL for r in routes))

"""The HTTP API: create_app() wires routes, auth, limits and the OpenAPI schema."""

from __future__ import annotations

import contextlib
import logging
import threading
from pathlib import Path

from fastapi import FastAPI
from fastapi.middleware.gzip import GZipMiddleware
from fastapi.openapi.utils import get_openapi
from fastapi.responses import JSONResponse

from app import __version__
from app.api import errors
from app.api.auth import auth_required
from app.api.routes import jobs, meta, robots
from app.api.schemas import spec_json_schema
from app.core.settings import Settings, get_settings


class BodyLimit:
    """Refuses a declared Content-Length above the limit before reading anything
    (streamed bodies are counted by the route that reads them). `wider`: paths allowed a
    larger body (robot uploads, app/api/routes/robots.py)."""

    def __init__(self, app, limit: int, wider: dict[str, int] | None = None):
        self.app, self.limit, self.wider = app, limit, wider or {}

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http":
            limit = self.wider.get(scope.get("path", "").rstrip("/"), self.limit)
            for k, v in scope.get("headers", ()):
                if k == b"content-length" and v.isdigit() and int(v) > limit:
                    msg = f"request body larger than {limit} bytes" + (
                        " (GAITMEND_MAX_BODY_BYTES)" if limit == self.limit else "")
                    resp = JSONResponse(errors.error_body(msg, [{"field": "body", "message": msg}]), status_code=413)
                    await resp(scope, receive, send)
                    return
        await self.app(scope, receive, send)


def install_docs(app: FastAPI) -> None:
    """/docs (Swagger UI) from assets an installed package ships (fastapi-offline), not from a
    CDN: the API docs work on a machine without internet. (No /redoc: its page fetches a
    logo from a CDN.)"""
    import fastapi_offline
    from fastapi.openapi.docs import get_swagger_ui_html
    from fastapi.staticfiles import StaticFiles

    assets = Path(fastapi_offline.__file__).parent / "static"
    app.mount("/docs-assets", StaticFiles(directory=assets), name="docs-assets")

    @app.get("/docs", include_in_schema=False)
    async def swagger_ui():
        return get_swagger_ui_html(openapi_url="/openapi.json", title="gaitmend API",
                                   swagger_js_url="/docs-assets/swagger-ui-bundle.js",
                                   swagger_css_url="/docs-assets/swagger-ui.css",
                                   swagger_favicon_url="/docs-assets/favicon.png")


def create_app(settings: Settings | None = None, host: str = "127.0.0.1", housekeeping: bool = False) -> FastAPI:
    """`host` is the address the server binds: auth is required unless it is loopback
    (GAITMEND_AUTH=on|off overrides). `housekeeping` runs the lease reaper in this process."""
    settings = settings or get_settings()

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        from app.store.migrate import ensure_schema

        settings.data_dir.mkdir(parents=True, exist_ok=True)  # the SQLite file's folder
        did = ensure_schema(settings.db_url)  # a bare uvicorn start migrates too (SchemaError: refuses)
        if did:
            logging.getLogger("gaitmend").warning("%s (at start-up)", did)
        keeper = None
        if housekeeping:
            from app.service.housekeeping import Housekeeper

            keeper = Housekeeper(settings)
            threading.Thread(target=keeper.loop, name="housekeeping", daemon=True).start()
        yield
        if keeper:
            keeper.stop()

    app = FastAPI(title="gaitmend", version=__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="Submit damage scenarios; workers search for gaits that walk again.")
    app.state.settings = settings
    app.state.auth_required = auth_required(settings.auth, host)
    errors.install(app)
    app.include_router(jobs.router, prefix="/api")
    app.include_router(robots.router, prefix="/api")  # built-in and uploaded robots (issue 23)
    app.include_router(meta.router, prefix="/api")
    from app.api.routes import studies

    app.include_router(studies.router, prefix="/api")
    from app.api.routes import media

    app.include_router(media.router, prefix="/api")  # a job's video and thumbnail
    from app.api.routes import adaptations  # adaptation sessions and their page (issue 44)

    app.include_router(adaptations.router, prefix="/api"), app.include_router(adaptations.page_router)
    app.add_middleware(BodyLimit, limit=settings.max_body_bytes, wider={"/api/robots": robots.MAX_BODY_BYTES})
    # JSON, pages and static files compressed on the wire (event streams and bodies already
    # compressed, such as the dashboard's gzipped plotly.min.js, pass through)
    app.add_middleware(GZipMiddleware, minimum_size=1024)

    install_docs(app)
    from app.api.routes import dashboard

    dashboard.install(app)  # the browser dashboard at / (app/api/routes/dashboard.py)

    def openapi():
        if app.openapi_schema is None:
            schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
            spec, defs = spec_json_schema()
            comps = schema.setdefault("components", {}).setdefault("schemas", {})
            comps.update(defs)
            comps["JobSpec"] = spec
            schema.setdefault("components", {})["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
            schema["security"] = [{"bearer": []}, {}]
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi
    return app

"""The browser dashboard: pages, static files, and the few read routes the pages need.

Everything the browser loads comes from this project (web/) or from installed Python
packages (plotly's plotly.min.js, viser's client build), so the dashboard works offline.
The routes here reuse the job service's auth dependency and repository functions, so a
token holder sees exactly the jobs the REST API shows them.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import hmac
import io
import math
import os
import secrets
import time
import zipfile
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, FastAPI, Path as PathParam, Query, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles

from app.api.auth import LOCAL_OWNER, Principal, principal
from app.api.errors import ApiError
from app.api.schemas import ERROR_RESPONSES, MEMBER_PATTERN
from app.store import repo
from app.store.db import session_scope

WEB_DIR = Path(os.environ.get("GAITMEND_WEB_DIR", Path(__file__).resolve().parent.parent / "web"))
# page name -> (template, title, the nav link marked as the current page)
PAGES = {"jobs": ("index.html", "jobs", "/"), "job": ("job.html", "job", None),
         "compare": ("compare.html", "compare", "/compare")}
NAV = (("/", "Jobs"), ("/compare", "Compare"), ("/docs", "API"))
HEADER_MARK = "<!-- gaitmend: header -->"
# Trace columns a plot uses; the rest (joint angles, quaternions, feet) stay in the bundle.
SKIP_PREFIXES = ("qpos_", "torso_quat_", "feet_m_", "torso_pos_m_")
MAX_POINTS = 800
LINK_TTL_S = 3600

JobId = Annotated[str, PathParam(min_length=1, max_length=64, description="job id")]


def _plotly_js() -> Path:
    import plotly

    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


def _viser_client() -> Path:
    import viser

    return Path(viser.__file__).parent / "client" / "build"


# -- signed links ------------------------------------------------------------------------------
# viser's client fetches ?playbackPath= with a plain GET and a browser download cannot send
# an Authorization header, so a token holder asks (with the header) for a short-lived link
# signed for one job and one file; the key lives in this process only.

# The link names the token it was made for (its row id; 0 without auth), so revoking the
# token kills its links too; `exp` is bounded before it is read as a number.

def _sign(key: bytes, job_id: str, path: str, exp: int, token_id: int) -> str:
    return hmac.new(key, f"{job_id}\n{path}\n{exp}\n{token_id}".encode(), hashlib.sha256).hexdigest()


def signed_url(key: bytes, job_id: str, path: str, token_id: int | None = None,
               ttl_s: int = LINK_TTL_S) -> tuple[str, int]:
    exp, tid = int(time.time()) + ttl_s, token_id or 0
    return f"/api/jobs/{job_id}/files/{path}?exp={exp}&sig={tid}.{_sign(key, job_id, path, exp, tid)}", exp


def _link_token(key: bytes, job_id: str, path: str, exp: str | None, sig: str | None) -> int | None:
    """The token id a valid, unexpired link was signed for (0: no token), else None."""
    if not exp or not sig or not (exp.isascii() and exp.isdigit()) or len(exp) > 12:
        return None
    tid, _, mac = sig.partition(".")
    if not (tid.isascii() and tid.isdigit() and len(tid) <= 12 and str(int(tid)) == tid and len(mac) == 64):
        return None
    now = time.time()
    if not now <= int(exp) <= now + LINK_TTL_S + 60:
        return None
    if not hmac.compare_digest(_sign(key, job_id, path, int(exp), int(tid)).encode(), mac.encode()):
        return None
    return int(tid)


# -- bundle members ----------------------------------------------------------------------------

def _member_name(path: str) -> str:
    parts = path.split("/")
    if not path or path.startswith("/") or any(p in ("", ".", "..") for p in parts) or "\\" in path:
        raise ApiError(422, f"not a file path inside a bundle: {path!r}", field="path")
    return path


@functools.lru_cache(maxsize=16)
def _members(bundle: str, mtime_ns: int) -> dict[str, int]:
    with zipfile.ZipFile(bundle) as z:
        return {i.filename: i.file_size for i in z.infolist() if not i.is_dir()}


def _read_member(bundle: str, name: str) -> bytes:
    with zipfile.ZipFile(bundle) as z:
        return z.read(name)


def _contact_intervals(t: list[float], contact: list[int]) -> list[list[float]]:
    """Swing phases (foot off the ground) of one leg as [start, end] times."""
    out, start = [], None
    for ti, c in zip(t, contact):
        if not c and start is None:
            start = ti
        elif c and start is not None:
            out.append([start, ti])
            start = None
    if start is not None:
        out.append([start, t[-1]])
    return out


def _num(x: str) -> float | None:
    if x == "":
        return None
    v = float(x)
    return v if math.isfinite(v) else None  # JSON has no NaN


@functools.lru_cache(maxsize=32)
def _traces(bundle: str, mtime_ns: int) -> dict[str, Any]:
    """Per trajectory: the plotted columns decimated to at most MAX_POINTS rows, and every
    leg's swing phases from the full-rate foot contacts."""
    import numpy as np

    out: dict[str, Any] = {}
    with zipfile.ZipFile(bundle) as z:
        names = sorted(n for n in z.namelist() if n.startswith("trajectories/") and n.endswith(".csv"))
        for name in names:
            key = name.removeprefix("trajectories/").removesuffix(".csv")
            rows = list(csv.reader(io.StringIO(z.read(name).decode())))
            if len(rows) < 2 or "time_s" not in rows[0]:
                continue
            header, body = rows[0], rows[1:]
            cols = {h: [r[i] for r in body] for i, h in enumerate(header) if not h.startswith(SKIP_PREFIXES)}
            num = {}
            for h, v in cols.items():
                try:
                    num[h] = [_num(x) for x in v]
                except ValueError:
                    continue
            t = num.pop("time_s")
            contact_cols = [h for h in num if h.startswith("foot_contact_")]
            legs = list(range(len(contact_cols)))
            npz = name.removesuffix(".csv") + ".npz"
            if npz in z.namelist():
                with np.load(io.BytesIO(z.read(npz))) as d:
                    if "legs" in d and len(d["legs"]) == len(contact_cols):
                        legs = [int(x) for x in d["legs"]]
            swing = {str(leg): _contact_intervals(t, [int(c or 0) for c in num[h]])
                     for leg, h in zip(legs, contact_cols)}
            step = max(1, -(-len(t) // MAX_POINTS))
            series = {h: v[::step] for h, v in num.items() if h not in contact_cols}
            out[key] = {"time_s": t[::step], "series": series, "legs": legs, "swing": swing,
                        "duration_s": t[-1] if t else 0.0, "rows": len(t)}
    return out


def render_page(path: Path, title: str, current: str | None) -> str:
    """A page template with the shared head and header (``templates/_header.html``) put in
    place of its first line's mark; the current page's nav link gets ``aria-current``."""
    current_attr = ' aria-current="page"'
    nav = "".join(f'<a href="{href}"{current_attr if href == current else ""}>{text}</a>' for href, text in NAV)
    header = (path.parent / "_header.html").read_text().replace("{title}", title).replace("{nav}", nav)
    return path.read_text().replace(HEADER_MARK, header.rstrip("\n"), 1)


# -- routes ------------------------------------------------------------------------------------

def install_dashboard(app: FastAPI) -> None:
    """Pages at /, /jobs/{id}, /compare; static files; plotly and viser's client; the read
    routes under /api/web and /api/jobs/{id}/files."""
    link_key = secrets.token_bytes(32)
    settings = app.state.settings

    def page(name: str):
        template, title, current = PAGES[name]
        path = WEB_DIR / "templates" / template

        async def handler():
            if not path.is_file():
                return HTMLResponse(f"<h1>gaitmend</h1><p>The dashboard files are missing ({path}); "
                                    "the API is at <a href='/docs'>/docs</a>.</p>", status_code=503)
            return HTMLResponse(render_page(path, title, current), headers={"Cache-Control": "no-cache"})

        return handler

    app.add_api_route("/", page("jobs"), include_in_schema=False, methods=["GET"])
    app.add_api_route("/jobs/{job_id}", page("job"), include_in_schema=False, methods=["GET"])
    app.add_api_route("/compare", page("compare"), include_in_schema=False, methods=["GET"])
    if (WEB_DIR / "static").is_dir():
        app.mount("/static", StaticFiles(directory=WEB_DIR / "static"), name="static")
    app.mount("/viser", StaticFiles(directory=_viser_client(), html=True), name="viser-client")

    plotly_js = _plotly_js()

    @app.get("/vendor/plotly.min.js", include_in_schema=False)
    async def plotly_min():
        return FileResponse(plotly_js, media_type="text/javascript",
                            headers={"Cache-Control": "public, max-age=86400"})

    async def db(fn):
        def call():
            with session_scope(settings.db_url, readonly=True) as s:
                return fn(s)

        try:
            return await run_in_threadpool(call)
        except repo.NotFound as e:
            raise ApiError(404, f"no job {str(e)!r}", field="id") from None

    async def _link_principal(token_id: int | None) -> Principal | None:
        if token_id is None:
            return None
        if token_id == 0:
            return Principal(LOCAL_OWNER, restricted=False)
        owner = await db(lambda s: repo.token_owner(s, token_id))
        return Principal(owner, restricted=True, token_id=token_id) if owner else None  # revoked: dead link

    async def bundle_of(job_id: str, who: Principal | None) -> str:
        owner = who.owner_filter if who is not None else None
        job = await db(lambda s: repo.get_job(s, job_id, owner))
        if job.status != "succeeded" or not job.bundle_path:
            raise ApiError(409, f"the bundle exists once the job succeeded; it is {job.status}", field="status")
        if not Path(job.bundle_path).is_file():
            raise ApiError(410, f"the bundle file is gone from the data folder: {Path(job.bundle_path).name}")
        return job.bundle_path

    @app.get("/api/jobs/{job_id}/files", tags=["dashboard"], responses=ERROR_RESPONSES)
    async def list_files(job_id: JobId, who: Principal = Depends(principal)) -> dict[str, int]:
        """Members of the job's result bundle with their sizes in bytes."""
        bundle = await bundle_of(job_id, who)
        return _members(bundle, os.stat(bundle).st_mtime_ns)

    @app.get("/api/jobs/{job_id}/file-link", tags=["dashboard"], responses=ERROR_RESPONSES)
    async def file_link(job_id: JobId, path: Annotated[str, Query(max_length=200, pattern=MEMBER_PATTERN)],
                        who: Principal = Depends(principal)):
        """A link to one bundle member that works without the Authorization header for an
        hour (for viser's ?playbackPath= and browser downloads)."""
        name = _member_name(path)
        bundle = await bundle_of(job_id, who)
        if name not in _members(bundle, os.stat(bundle).st_mtime_ns):
            raise ApiError(404, f"the bundle has no file {name!r}", field="path")
        url, exp = signed_url(link_key, job_id, name, who.token_id)
        return {"url": url, "expires_at": exp}

    @app.get("/api/jobs/{job_id}/files/{path:path}", tags=["dashboard"],
             responses=ERROR_RESPONSES | {200: {"content": {"application/octet-stream": {}}}})
    async def read_file(request: Request, job_id: JobId,
                        path: Annotated[str, PathParam(max_length=200, pattern=MEMBER_PATTERN)], exp: str | None = None,
                        sig: str | None = None):
        """One member of the result bundle (replay.viser, trajectories/best.csv, plots/...).
        Authorised like the other job routes, or by a link from /file-link."""
        name = _member_name(path)
        who = await _link_principal(_link_token(link_key, job_id, name, exp, sig)) or await principal(request)
        bundle = await bundle_of(job_id, who)
        if name not in _members(bundle, os.stat(bundle).st_mtime_ns):
            raise ApiError(404, f"the bundle has no file {name!r}", field="path")
        data = await run_in_threadpool(_read_member, bundle, name)
        media = {".json": "application/json", ".csv": "text/csv", ".svg": "image/svg+xml", ".png": "image/png",
                 ".md": "text/markdown", ".xml": "application/xml"}.get(Path(name).suffix,
                                                                          "application/octet-stream")
        return Response(data, media_type=media, headers={"Cache-Control": "private, max-age=3600"})

    @app.get("/api/jobs/{job_id}/traces", tags=["dashboard"], responses=ERROR_RESPONSES)
    async def traces(job_id: JobId, who: Principal = Depends(principal)):
        """The bundle's trajectories for plotting: time, body angles, CoM and the other
        per-step scalars at most 800 points each, and per-leg swing phases at full rate."""
        bundle = await bundle_of(job_id, who)
        data = await run_in_threadpool(_traces, bundle, os.stat(bundle).st_mtime_ns)
        return JSONResponse(data, headers={"Cache-Control": "private, max-age=3600"})

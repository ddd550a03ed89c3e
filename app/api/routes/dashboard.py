"""The browser dashboard: pages, static files, and the few read routes the pages need.

Everything the browser loads comes from this project (web/) or from installed Python
packages (plotly's plotly.min.js, viser's client build), so the dashboard works offline.
The routes (``router``; ``install`` adds them with the static files) reuse the job
service's auth and database dependencies and repository functions, so a token holder
sees exactly the jobs the REST API shows them.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import io
import json
import math
import os
import re
import secrets
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Depends, FastAPI, Path as PathParam, Query, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles

from app.api import job_overview
from app.api.auth import LOCAL_OWNER, Principal, principal
from app.api.deps import Db, db_of, get_db, settings_of
from app.api.errors import ApiError
from app.api.routes.studies import _study_schema
from app.api.schemas import ERROR_RESPONSES, MEMBER_PATTERN
from app.core import colors
from app.core.assets import asset_dir
from app.store import repo
from app.store.models import FINAL

WEB_DIR = Path(os.environ.get("GAITMEND_WEB_DIR") or asset_dir("web"))
# page name -> (template, title, the nav link marked as the current page)
PAGES = {"jobs": ("index.html", "jobs", "/"), "job": ("job.html", "job", None),
         "compare": ("compare.html", "compare", "/compare"),
         "studies": ("studies.html", "studies", "/studies"),  # app/studies
         "robot_add": ("robot_add.html", "add robot", "/robots/new")}
NAV = (("/", "Jobs"), ("/studies", "Studies"), ("/compare", "Compare"), ("/robots/new", "Add robot"), ("/docs", "API"))
HEADER_MARK = "<!-- gaitmend: header -->"
LINK_TTL_S = 3600

JobId = Annotated[str, PathParam(min_length=1, max_length=64, description="job id")]


# plotly.js as two bundles of one release: the full one from the plotly package (4.8 MB) and
# its cartesian build (scatter, bar, heatmap: 1.5 MB; web/vendor, scripts/vendor_plotly.sh),
# which most pages draw with; common.js picks by the traces a page draws.
PLOTLY_BUNDLES = ("plotly", "plotly-cartesian")


@functools.lru_cache(maxsize=2)
def _plotly_js(name: str = "plotly") -> Path:
    if name == "plotly-cartesian":
        return WEB_DIR / "vendor" / "plotly-cartesian.min.js"
    import plotly

    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


# A script that starts with this comment has every function compiled while it streams in,
# off the page's thread (V8's explicit compile hints, Chrome 136 on; to other browsers it is
# a comment). Both bundles carry it: the cartesian one's start-up then takes about 40 ms of a
# cold job page's thread, not 140 (issue 25; Chromium traces, see docs/dashboard.md); the
# full one (a tipping page with its polar sweep, the robot page's 3D legs) is evaluated in
# about 0.55 s of the page's thread instead of 0.95 (thread time in Chromium traces of a cold
# tipping page, 5-6 loads each way, alternating, load average 7-12 on 2 cores); its
# background parse takes about 0.3 s more, off that thread, and the page's whole work less.
COMPILE_HINT = b"//# allFunctionsCalledOnLoad\n"


def _plotly_bytes(name: str) -> bytes:
    """A bundle as served: the compile hint, then the file's bytes unchanged."""
    return COMPILE_HINT + _plotly_js(name).read_bytes()


@functools.lru_cache(maxsize=2)
def _plotly_gz(name: str = "plotly") -> bytes:
    """A bundle gzipped once (4.8 MB to about 1.4 MB; the cartesian 1.5 MB to 0.5 MB):
    compressing it per request would cost a quarter of a second of CPU each time."""
    import gzip

    return gzip.compress(_plotly_bytes(name), compresslevel=6, mtime=0)


@functools.lru_cache(maxsize=1)
def _plotly_version() -> str:
    import plotly

    return plotly.__version__


IMMUTABLE = "public, max-age=31536000, immutable"  # a versioned URL (?v=) never changes


@functools.lru_cache(maxsize=64)
def _static_version(name: str, mtime_ns: int) -> str:
    return hashlib.sha256((WEB_DIR / "static" / name).read_bytes()).hexdigest()[:12]


def _versioned(match) -> str:
    name = match.group(1)
    path = WEB_DIR / "static" / name
    if not path.is_file():
        return match.group(0)
    return f"/static/{name}?v={_static_version(name, path.stat().st_mtime_ns)}"


class CachedStatic(StaticFiles):
    """web/static with caching headers: a URL with ?v= (the pages name every file so, with
    its content hash) is cached for a year; without it the browser revalidates (ETag)."""

    async def get_response(self, path, scope):
        resp = await super().get_response(path, scope)
        versioned = b"v=" in scope.get("query_string", b"")
        resp.headers["Cache-Control"] = IMMUTABLE if versioned and resp.status_code == 200 else "no-cache"
        return resp


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


def _jsonable(x: Any) -> Any:
    """numpy scalars to Python, NaN and infinities to None (JSON has neither)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if hasattr(x, "tolist") and not isinstance(x, (str, bytes)):
        return _jsonable(x.tolist())
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _kind(name: str | None):
    from app.jobs.registry import KINDS

    return KINDS.get(name) if isinstance(name, str) else None


def _panels_of_tables(tables: list[dict]) -> list[dict]:
    return [{"id": f"table-{i}", "title": t.get("title", ""), "caption": " ".join(t.get("notes") or []),
             "table": {"columns": list(t.get("columns", [])), "rows": [list(r) for r in t.get("rows", [])]}}
            for i, t in enumerate(tables)]


def _as_panel(item: dict, i: int) -> dict:
    """A kind's view: a panel already, or a bare plotly figure dict ({"data", "layout"})."""
    if "figure" in item or "table" in item:
        return item
    layout = dict(item.get("layout") or {})
    title = layout.pop("title", None) or {}  # the card's heading says it; inside, it would sit on the legend
    title = title.get("text", "") if isinstance(title, dict) else str(title)
    return {"id": f"view-{i}", "title": title or f"Figure {i + 1}", "caption": "",
            "figure": {"data": item.get("data", []), "layout": layout}}


@functools.lru_cache(maxsize=16)
def _bundle_views(bundle: str, mtime_ns: int) -> dict[str, Any]:
    """What the kind shows of its result (headline rows, tables, plotly figures) plus the
    shared evidence tables, computed once per bundle from result.json and the trajectories."""
    import numpy as np

    from app.jobs.viewkit import controls_panel, robustness_panel
    from app.results import replay

    with zipfile.ZipFile(bundle) as z:
        members = [n for n in z.namelist() if not n.endswith("/")]
        summary = json.loads(z.read("result.json"))
        kind_name = json.loads(z.read("manifest.json")).get("kind") or summary.get("kind")
        traces = {}
        for n in members:
            if n.startswith("trajectories/") and n.endswith(".npz"):
                traces[n.removeprefix("trajectories/").removesuffix(".npz")] = np.load(io.BytesIO(z.read(n)))
    kind = _kind(kind_name)
    out: dict[str, Any] = {"kind": kind_name, "headline": [], "panels": [], "evidence": [], "describe": {}, "replay": [],
                           "verdict": None}
    names = None
    if kind is not None:
        out["headline"] = list(kind.headline(summary))
        out["verdict"] = kind.verdict(summary)
        names = kind.metric_names(summary)
        out["panels"] = [_as_panel(v, i) for i, v in enumerate(kind.views(summary, traces))]
        out["panels"] += _panels_of_tables(list(kind.page_tables(summary)))
        replayable = [n for n, tr in traces.items() if "qpos" in tr.files]
        tracks = [t for t in sorted(kind.replay_style(replayable), key=lambda t: t.order) if t.name in replayable]
        # each track's own scene (an older bundle has one replay.viser with every track side by side)
        scenes = {n: p for n, p in replay.scene_paths([t.name for t in tracks]).items() if p in members}
        out["describe"] = dict(kind.bundle_rows(members)) | {p: d for p, d in replay.scene_rows(tracks).items()
                                                            if p in members and len(scenes) == len(tracks)}
        out["replay"] = [{"name": t.name, "label": t.label, "color": t.color, "path": scenes.get(t.name)}
                         for t in tracks]
    out["evidence"] = [p for p in (controls_panel(summary, names), robustness_panel(summary, names)) if p]
    return _jsonable(out)


def _budget(spec) -> dict[str, Any]:
    """The evaluation budget as the spec states it: one formula for the form and the compare page."""
    formula = getattr(spec, "budget_formula", None)
    if callable(formula):
        formula = formula()
    return {"evaluations": int(spec.evaluations_budget), "formula": formula}


def _form_schema(spec_cls) -> dict[str, Any]:
    """A Spec's JSON schema with every default in it, those made by a default factory too
    (pydantic leaves them out): the form shows what an untouched field runs, e.g. the damage
    a kind assumes when the spec names none."""
    from pydantic.json_schema import GenerateJsonSchema

    class WithFactoryDefaults(GenerateJsonSchema):
        def get_default_value(self, schema):
            factory = schema.get("default_factory")
            if factory is not None and not schema.get("default_factory_takes_data"):
                return factory()
            return super().get_default_value(schema)

    return spec_cls.model_json_schema(schema_generator=WithFactoryDefaults)


@functools.lru_cache(maxsize=1)
def _kinds() -> list[dict]:
    from app.jobs.registry import KINDS

    return [{"name": name, "title": kind.title, "paper": kind.paper, "description": kind.title,
             "schema": _form_schema(kind.Spec), "open": list(kind.form_open)} for name, kind in KINDS.items()]


def render_page(path: Path, title: str, current: str | None) -> str:
    """A page template with the shared head and header (``templates/_header.html``) put in
    place of its first line's mark; the current page's nav link gets ``aria-current``; the
    colour table of app/core/colors.py goes into the head as JSON (common.js reads it)."""
    current_attr = ' aria-current="page"'
    nav = "".join(f'<a href="{href}"{current_attr if href == current else ""}>{text}</a>' for href, text in NAV)
    header = (path.parent / "_header.html").read_text().replace("{title}", title).replace("{nav}", nav)
    header = header.replace("{colors}", json.dumps(colors.page_table()).replace("</", "<\\/"))
    page = path.read_text().replace(HEADER_MARK, header.rstrip("\n"), 1)
    for name in PLOTLY_BUNDLES:  # the head names both; a page's preload names the one it draws with
        page = page.replace("{%s}" % name.replace("-", "_"), f"/vendor/{name}.min.js?v={_plotly_version()}")
    return re.sub(r'/static/([A-Za-z0-9_.-]+\.(?:js|css))(?=")', _versioned, page)


# -- routes ------------------------------------------------------------------------------------

router = APIRouter()


def install(app: FastAPI) -> None:
    """The dashboard on ``app``: its routes (``router``), the static files, plotly and
    viser's client, and the key of this process's signed links."""
    app.state.link_key = secrets.token_bytes(32)
    app.include_router(router)
    if (WEB_DIR / "static").is_dir():
        app.mount("/static", CachedStatic(directory=WEB_DIR / "static"), name="static")
    app.mount("/viser", StaticFiles(directory=_viser_client(), html=True), name="viser-client")


def _link_key(request: Request) -> bytes:
    return request.app.state.link_key


def _page(name: str):
    template, title, current = PAGES[name]
    path = WEB_DIR / "templates" / template

    async def handler():
        if not path.is_file():
            return HTMLResponse(f"<h1>gaitmend</h1><p>The dashboard files are missing ({path}); "
                                "the API is at <a href='/docs'>/docs</a>.</p>", status_code=503)
        return HTMLResponse(render_page(path, title, current), headers={"Cache-Control": "no-cache"})

    return handler


for _path, _name in (("/", "jobs"), ("/jobs/{job_id}", "job"), ("/compare", "compare"), ("/studies", "studies"),
                     ("/studies/{study_id}", "studies"), ("/robots/new", "robot_add")):
    router.add_api_route(_path, _page(_name), include_in_schema=False, methods=["GET"])


@router.get("/robots", include_in_schema=False)
async def robots_page():
    """The robots (built-in and yours) are listed on the page that adds one: /robots, where a
    newcomer looks first, goes there (307: a later list page of its own may take /robots)."""
    return RedirectResponse("/robots/new", status_code=307)


@router.get("/vendor/{name}.min.js", include_in_schema=False)
async def plotly_min(request: Request, name: str, v: str | None = None):
    """A plotly.js bundle (``PLOTLY_BUNDLES``), gzipped when the browser takes it; cached for a
    year under its versioned URL (?v=<plotly version>, as the pages name it)."""
    if name not in PLOTLY_BUNDLES:
        raise ApiError(404, f"no vendored script {name!r}; there are {', '.join(PLOTLY_BUNDLES)}", field="name")
    cache = IMMUTABLE if v == _plotly_version() else "public, max-age=86400"
    headers = {"Cache-Control": cache, "Vary": "Accept-Encoding"}
    if "gzip" in request.headers.get("accept-encoding", ""):
        data = await run_in_threadpool(_plotly_gz, name)
        return Response(data, media_type="text/javascript", headers=headers | {"Content-Encoding": "gzip"})
    return Response(await run_in_threadpool(_plotly_bytes, name), media_type="text/javascript", headers=headers)


async def _link_principal(db: Db, token_id: int | None) -> Principal | None:
    if token_id is None:
        return None
    if token_id == 0:
        return Principal(LOCAL_OWNER, restricted=False)
    owner = await db.read(lambda s: repo.token_owner(s, token_id))
    return Principal(owner, restricted=True, token_id=token_id) if owner else None  # revoked: dead link


async def _bundle_of(db: Db, job_id: str, who: Principal | None) -> str:
    owner = who.owner_filter if who is not None else None
    job = await db.read(lambda s: repo.get_job(s, job_id, owner))
    if job.status != "succeeded" or not job.bundle_path:
        raise ApiError(409, f"the bundle exists once the job succeeded; it is {job.status}", field="status")
    if not Path(job.bundle_path).is_file():
        raise ApiError(410, f"the bundle file is gone from the data folder: {Path(job.bundle_path).name}")
    return job.bundle_path


def _member_of(bundle: str, name: str) -> str:
    if name not in _members(bundle, os.stat(bundle).st_mtime_ns):
        raise ApiError(404, f"the bundle has no file {name!r}", field="path")
    return name


@router.get("/api/jobs/{job_id}/files", tags=["dashboard"], responses=ERROR_RESPONSES)
async def list_files(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)) -> dict[str, int]:
    """Members of the job's result bundle with their sizes in bytes."""
    bundle = await _bundle_of(db, job_id, who)
    return _members(bundle, os.stat(bundle).st_mtime_ns)


@router.get("/api/jobs/{job_id}/file-link", tags=["dashboard"], responses=ERROR_RESPONSES)
async def file_link(request: Request, job_id: JobId,
                    path: Annotated[str, Query(max_length=200, pattern=MEMBER_PATTERN)],
                    who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """A link to one bundle member that works without the Authorization header for an
    hour (for viser's ?playbackPath= and browser downloads)."""
    name = _member_name(path)
    _member_of(await _bundle_of(db, job_id, who), name)
    url, exp = signed_url(_link_key(request), job_id, name, who.token_id)
    return {"url": url, "expires_at": exp}


MEDIA_TYPES = {".json": "application/json", ".csv": "text/csv", ".svg": "image/svg+xml", ".png": "image/png",
               ".md": "text/markdown", ".xml": "application/xml"}


@router.get("/api/jobs/{job_id}/files/{path:path}", tags=["dashboard"],
            responses=ERROR_RESPONSES | {200: {"content": {"application/octet-stream": {}}}})
async def read_file(request: Request, job_id: JobId,
                    path: Annotated[str, PathParam(max_length=200, pattern=MEMBER_PATTERN)], exp: str | None = None,
                    sig: str | None = None, db: Db = Depends(get_db)):
    """One member of the result bundle (replay.viser, trajectories/best.csv, plots/...).
    Authorised like the other job routes, or by a link from /file-link."""
    name = _member_name(path)
    who = await _link_principal(db, _link_token(_link_key(request), job_id, name, exp, sig)) \
        or await principal(request)
    bundle = await _bundle_of(db, job_id, who)
    data = await run_in_threadpool(_read_member, bundle, _member_of(bundle, name))
    media = MEDIA_TYPES.get(Path(name).suffix, "application/octet-stream")
    return Response(data, media_type=media, headers={"Cache-Control": "private, max-age=3600"})


@router.get("/api/web/kinds", tags=["dashboard"], responses=ERROR_RESPONSES)
async def kinds() -> list[dict]:
    """Every registered job kind with the JSON schema of its spec (the form is built
    from it) and the groups of fields the kind wants opened first."""
    return await run_in_threadpool(_kinds)


@router.post("/api/web/check", tags=["dashboard"], responses=ERROR_RESPONSES,
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/json": {"schema": {"$ref": "#/components/schemas/JobSpec"}}}}})
async def check(request: Request, who: Principal = Depends(principal)):
    """Validate a spec without queuing it: its evaluation budget (the spec's own
    formula, the number the compare page shows) and the wall time it will take at this
    server's measured rate (app/api/job_overview.py), or the API's field errors, including an
    uploaded robot's (a damage it cannot stand on), so the form never asks to confirm a
    long job that POST /api/jobs would refuse."""
    from app.api.routes.jobs import accepted_spec

    db = db_of(request)
    spec = await accepted_spec(request, settings_of(request), who, db)  # what POST /api/jobs accepts
    rate = await db.read(job_overview.rates)
    return _budget(spec) | {"estimate": job_overview.estimate(spec.kind, int(spec.evaluations_budget), rate)}


def _stored_budget(spec: dict | None) -> dict[str, Any] | None:
    from app.jobs.registry import parse_spec

    try:
        return _budget(parse_spec(spec))
    except Exception:  # a spec stored by an older version: no budget shown, the rest still is
        return None


async def _result_views(bundle: str, link: Callable[[str], str]) -> dict[str, Any]:
    """A succeeded job's page parts from its bundle: the kind's views and the evidence, every
    member with a short-lived download link (``link(path)``) and what it is, and the plots."""
    mtime = os.stat(bundle).st_mtime_ns
    v = await run_in_threadpool(_bundle_views, bundle, mtime)
    files = [{"path": n, "size": size, "what": v["describe"].get(n, ""), "url": link(n)}
             for n, size in _members(bundle, mtime).items()]
    figs: dict[str, dict] = {}
    for f in files:
        p = Path(f["path"])
        if p.parts[0] == "plots" and p.suffix in (".png", ".svg"):
            figs.setdefault(p.stem, {"name": p.stem, "what": v["describe"].get(f["path"], "")})[p.suffix[1:]] = f["url"]
    # SVG, PNG or both: the contract asks for either
    return {**{k: v[k] for k in ("headline", "panels", "evidence", "replay", "verdict")}, "files": files,
            "figures": list(figs.values())}


@router.get("/api/jobs/{job_id}/views", tags=["dashboard"], responses=ERROR_RESPONSES)
async def views(request: Request, job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """What the job page shows, supplied by the job's kind: what its history columns mean
    (units, which way is better), while it is queued or running its place in the queue and
    ETA, and once it succeeded its verdict (target, controls, robustness at a glance), its
    headline rows, tables and plotly figures, the controls and robustness tables, and every
    bundle member with a short-lived download link and what it is."""
    def read(s):
        job = repo.get_job(s, job_id, who.owner_filter)
        return job, job_overview.queue_info(s, job, job_overview.rates(s)) if job.status not in FINAL else None

    job, queue = await db.read(read)
    kind = _kind(job.kind)
    out: dict[str, Any] = {"kind": job.kind, "status": job.status,
                           "convergence": kind.history_axis(job.spec or {}) if kind is not None else None,
                           "damage_label": kind.damage_label if kind is not None else "Damage",
                           "budget": _stored_budget(job.spec), "headline": [], "panels": [], "evidence": [],
                           "files": [], "figures": [], "replay": [], "verdict": None, "queue": queue}
    if job.status == "succeeded" and job.bundle_path and Path(job.bundle_path).is_file():
        key = _link_key(request)
        out.update(await _result_views(job.bundle_path, lambda n: signed_url(key, job_id, n, who.token_id)[0]))
    elif job.summary and kind is not None:
        try:
            out["headline"] = _jsonable(list(kind.headline(job.summary)))
        except Exception:  # a failed job's partial summary: no headline
            pass
    return JSONResponse(out, headers={"Cache-Control": "private, no-cache"})


@router.get("/api/web/rows", tags=["dashboard"], responses=ERROR_RESPONSES)
async def rows(ids: Annotated[str, Query(max_length=3400, pattern=r"^[0-9a-f]{1,32}(,[0-9a-f]{1,32}){0,99}$")],
               who: Principal = Depends(principal), db: Db = Depends(get_db)) -> dict[str, dict]:
    """What the jobs list shows beside each job (up to 100 ids): its seed, budget and study,
    once succeeded the kind's list headline and its verdict in brief, while queued or running
    its place in the queue and ETA. Ids the caller may not see are left out."""
    wanted = list(dict.fromkeys(ids.split(",")))
    return _jsonable(await db.read(lambda s: job_overview.rows(s, wanted, who.owner_filter)))


@router.post("/api/web/study-check", tags=["dashboard"], responses=ERROR_RESPONSES,
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/json": {"schema": _study_schema()}}}})
async def study_check(request: Request, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """Validate a study without queueing it: its points, their evaluations and the wall
    time they will take at this server's measured rates, or the field errors."""
    from app.api.body import BodyError, parse_json
    from app.api.routes.jobs import _read_body, _require_json
    from app.jobs.base import SpecError
    from app.studies.study_bundle import load_study_file
    from app.studies.spec import expand

    settings = settings_of(request)
    _require_json(request)
    try:
        data = load_study_file(parse_json(await _read_body(request, settings.max_body_bytes)))
    except BodyError as e:
        raise ApiError(422, f"the body is not an acceptable JSON document: {e}", errors=e.errors) from None
    try:
        plan = await run_in_threadpool(expand, data)
    except SpecError as e:
        raise ApiError(422, str(e), errors=e.errors) from None
    est = await db.read(lambda s: job_overview.study_estimate(s, plan.points))
    return {"name": plan.study.name, "metrics": plan.study.report.metrics, "infeasible": len(plan.infeasible), **est}

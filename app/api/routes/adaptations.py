"""/api/adaptations: adaptation sessions over repertoires (issue 44), trials as a
sub-resource, each proposal downloadable for the robot, and the session's page. Each route
validates, calls one repository function (app/store/repo/adaptations.py) in one
transaction, and answers JSON; a refused request writes nothing and names its field."""

from __future__ import annotations

import io
import zipfile
from typing import Annotated

from fastapi import APIRouter, Depends, Path as PathParam, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import HTMLResponse

from app.api.auth import Principal, principal
from app.api.body import BodyError, parse_json
from app.api.deps import Db, get_db, settings_of
from app.api.errors import ApiError
from app.api.routes.jobs import ERRORS, _read_body, _require_json
from app.api.schemas import adaptation_body_schema
from app.jobs.base import SpecError
from app.store import repo

router = APIRouter(prefix="/adaptations", tags=["adaptations"])
AdaptationId = Annotated[str, PathParam(min_length=1, max_length=64, description="adaptation session id")]


async def _body(request: Request, parse):
    _require_json(request)
    raw = await _read_body(request, settings_of(request).max_body_bytes)
    try:
        data = parse_json(raw)
    except BodyError as e:
        raise ApiError(422, f"the body is not an acceptable JSON document: {e}", errors=e.errors) from None
    try:
        return parse(data)
    except SpecError as e:
        raise ApiError(422, str(e), errors=e.errors) from None


async def _run(db: Db, fn, write: bool = False):
    """``fn(session)`` in one transaction; a session's Refused is its status naming its field."""
    try:
        return await (db.write(fn, missing="adaptation session") if write else
                      db.read(fn, missing="adaptation session"))
    except repo.Refused as e:
        raise ApiError(e.status, str(e), field=e.field) from None


@router.post("", status_code=201, responses=ERRORS, openapi_extra={"requestBody": {"required": True, "content": {
             "application/json": {"schema": adaptation_body_schema("SessionSpec")}}}})
async def create(request: Request, response: Response, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """Start a session over one or more of your finished repertoire jobs: the method, the
    trial length and the stop rule. The answer holds the first gait to run (``next``)."""
    from app.adapt.session import SessionSpec

    spec = await _body(request, SessionSpec.parse)
    data_dir = settings_of(request).data_dir

    def fn(s):
        from app.store import robots as robot_store

        row = repo.create_adaptation(s, spec, owner=who.name, owner_filter=who.owner_filter,
                                     robots=lambda rid: robot_store.load_robot(s, data_dir, rid, who.owner_filter))
        return repo.adaptation_json(s, row)

    out = await _run(db, fn, write=True)
    response.headers["Location"] = out["links"]["self"]
    return out


@router.get("", responses=ERRORS)
async def list_sessions(who: Principal = Depends(principal), db: Db = Depends(get_db),
                        limit: Annotated[int, Query(ge=1, le=500)] = 50):
    """Your sessions, newest first."""
    return {"items": await _run(db, lambda s: [repo.adaptation_json(s, r, detail=False)
                                               for r in repo.list_adaptations(s, who.owner_filter, limit)])}


@router.get("/{adaptation_id}", responses=ERRORS)
async def get_one(adaptation_id: AdaptationId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The session: its trials in order, the stop decision and why, the gait to run next."""
    return await _run(db, lambda s: repo.adaptation_json(s, repo.get_adaptation(s, adaptation_id, who.owner_filter)))


@router.get("/{adaptation_id}/trials", responses=ERRORS)
async def list_trials(adaptation_id: AdaptationId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The measured trials, in order."""
    return {"items": await _run(db, lambda s: repo.trials_json(s, adaptation_id, who.owner_filter))}


@router.post("/{adaptation_id}/trials", status_code=201, responses=ERRORS, openapi_extra={"requestBody": {
             "required": True, "content": {"application/json": {"schema": adaptation_body_schema("TrialIn")}}}})
async def post_trial(request: Request, adaptation_id: AdaptationId, who: Principal = Depends(principal),
                     db: Db = Depends(get_db)):
    """Post what the lab measured of trial ``trial`` (the gait the session proposed for it).
    The answer is the session after it: the trial stored, the stop decision and why, and the
    next gait (``next``, null once the session stops). A number already stored or not the
    next one, and a finished session, are 409 naming the field; nothing is written."""
    from app.adapt.session import TrialIn

    t = await _body(request, TrialIn.parse)

    def fn(s):
        return repo.adaptation_json(s, repo.post_trial(s, adaptation_id, t, who.owner_filter))

    return await _run(db, fn, write=True)


@router.get("/{adaptation_id}/proposals/{trial}/bundle", responses=ERRORS | {200: {"content": {
            "application/zip": {}}, "description": "the gait for the robot: set-points and the controller module"}})
async def proposal_bundle(adaptation_id: AdaptationId, trial: Annotated[int, PathParam(ge=1, le=100)],
                          who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The gait proposed for trial ``trial`` (a stored trial's, or the next one) as files for
    the robot: setpoints.csv, gait.json, the repertoire's controller module and layout."""
    files = await _run(db, lambda s: repo.proposal_bundle(s, adaptation_id, trial, who.owner_filter))

    def pack() -> bytes:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            for name in sorted(files):
                z.writestr(name, files[name])
        return buf.getvalue()

    data = await run_in_threadpool(pack)
    return Response(data, media_type="application/zip", headers={
        "Content-Disposition": f'attachment; filename="adaptation-{adaptation_id[:12]}-trial{trial}.zip"'})


@router.get("/{adaptation_id}/views", responses=ERRORS)
async def views(adaptation_id: AdaptationId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The session's page plots: the map coloured by the prior and by the posterior."""
    from app.adapt.views import map_panels

    return {"panels": await _run(db, lambda s: map_panels(*repo.session_state(
        s, repo.get_adaptation(s, adaptation_id, who.owner_filter))))}


page_router = APIRouter()


@page_router.get("/adaptations/{adaptation_id}", include_in_schema=False)
async def page(adaptation_id: AdaptationId):
    from app.api.routes.dashboard import WEB_DIR, render_page

    path = WEB_DIR / "templates" / "adaptation.html"
    return HTMLResponse(render_page(path, "adaptation", None), headers={"Cache-Control": "no-cache"})

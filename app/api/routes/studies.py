"""/api/studies: a study fans out into ordinary jobs (app/studies); everything shown is
computed from those jobs' rows."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path as PathParam, Query, Request, Response
from fastapi.concurrency import run_in_threadpool

from app.api.auth import Principal, principal
from app.api.body import BodyError, parse_json
from app.api.deps import Db, get_db, settings_of
from app.api.errors import ApiError
from app.api.schemas import BuiltinStudyList
from app.api.routes.jobs import ERRORS, _read_body, _require_json
from app.service.dispatch import send
from app.jobs.base import SpecError
from app.store import repo
from app.studies import catalog, store
from app.studies.study_bundle import load_study_file, study_files, zip_bytes
from app.studies.spec import expand

router = APIRouter(prefix="/studies", tags=["studies"])
StudyId = Annotated[str, PathParam(min_length=1, max_length=64, description="study id")]


def _out(study, c: dict[str, int], jobs=None) -> dict[str, Any]:
    out = {"id": study.id, "name": study.name, "owner": study.owner, "created_at": study.created_at.isoformat(),
           "status": store.status_of(c), "progress": store.progress(c, study.points),
           "links": {"self": f"/api/studies/{study.id}", "bundle": f"/api/studies/{study.id}/bundle",
                     "page": f"/studies/{study.id}", "views": f"/api/studies/{study.id}/views"}}
    if jobs is not None:
        rows = store.point_rows(study, jobs)
        out["spec"] = study.spec
        out["infeasible"] = study.plan["infeasible"]
        out["aggregate"] = store.study_aggregate(study, jobs)
        out["jobs"] = [{"index": r["index"], "overrides": r["overrides"], "id": r["job_id"], "status": r["status"],
                        "error": r["error"], "link": f"/api/jobs/{r['job_id']}"} for r in rows]
    return out


def _study_schema() -> dict:
    """StudySpec's JSON schema with its definitions inlined (an operation's body schema
    cannot carry $defs of its own)."""
    import json

    from app.studies.spec import StudySpec

    sch = StudySpec.model_json_schema()
    defs = sch.pop("$defs", {})
    text = json.dumps(sch)
    for name, d in defs.items():
        text = text.replace(json.dumps({"$ref": f"#/$defs/{name}"}), json.dumps(d))
    return json.loads(text)


@router.post("", status_code=201, responses=ERRORS, openapi_extra={"requestBody": {"required": True, "content": {
             "application/json": {"schema": _study_schema()}}}})
async def submit_study(request: Request, response: Response, who: Principal = Depends(principal),
                       db: Db = Depends(get_db)):
    """Queue a study: every point is validated first; one bad point rejects the whole study
    (the error names the point and the field) and nothing is written."""
    settings = settings_of(request)
    _require_json(request)
    body = await _read_body(request, settings.max_body_bytes)
    try:
        data = load_study_file(parse_json(body))
    except BodyError as e:
        raise ApiError(422, f"the body is not an acceptable JSON document: {e}", errors=e.errors) from None
    try:
        plan = await run_in_threadpool(expand, data)
    except SpecError as e:
        raise ApiError(422, str(e), errors=e.errors) from None
    for p in plan.points:
        if p["budget"] > settings.max_evaluations_per_job:
            raise ApiError(422, f"point {p['index']} needs {p['budget']} evaluations; the limit is "
                                f"{settings.max_evaluations_per_job} per job (GAITMEND_MAX_EVALUATIONS_PER_JOB)",
                           field=f"points[{p['index']}].search.generations")

    def create_and_send():
        with db.session() as s:
            from app.studies.fair import window

            study, ids = store.create_study(s, plan, owner=who.name, max_attempts=settings.max_attempts,
                                            max_queued=settings.max_queued_per_owner,
                                            redispatch_after_s=settings.redispatch_after_s,
                                            window_=window(s, settings.reaper_interval_s))
            sid = study.id
        send(settings, ids)
        with db.session(readonly=True) as s:
            st = store.get_study(s, sid, None)
            return _out(st, store.counts(s, [sid])[sid], store.study_jobs(s, sid))

    try:
        out = await run_in_threadpool(create_and_send)
    except repo.QueueFull as e:
        raise ApiError(429, f"the study's {len(plan.points)} points would make {e.queued} queued jobs for "
                            f"{who.name!r}; the limit is {e.limit} (GAITMEND_MAX_QUEUED_PER_OWNER)",
                       field="points") from None
    response.headers["Location"] = out["links"]["self"]
    return out


@router.get("", responses=ERRORS)
async def list_studies(who: Principal = Depends(principal), db: Db = Depends(get_db),
                       limit: Annotated[int, Query(ge=1, le=500)] = 50):
    def fn(s):
        rows = store.list_studies(s, who.owner_filter, limit)
        c = store.counts(s, [r.id for r in rows])
        return {"items": [_out(r, c[r.id]) for r in rows]}

    return await db.read(fn, missing="study")


@router.get("/builtin", response_model=BuiltinStudyList, responses=ERRORS)
async def builtin_studies():
    """The built-in studies every registered kind ships (app/jobs/<kind>/studies/), in
    registry order, each kind's paper table first: name, kind and title."""
    return {"items": catalog.listing()}


@router.get("/builtin/{name}", responses=ERRORS)
async def builtin_study(name: Annotated[str, PathParam(pattern=r"^[a-z0-9_]{1,64}$")]):
    """A built-in study spec shipped with gaitmend (its kind's app/jobs/<kind>/studies/NAME.json)."""
    study = catalog.builtin_study(name)
    if study is None:
        raise ApiError(404, f"no built-in study {name!r}; allowed: {', '.join(catalog.builtin_studies())}",
                       field="name")
    return study


@router.get("/{study_id}", responses=ERRORS)
async def get_study(study_id: StudyId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    def fn(s):
        st = store.get_study(s, study_id, who.owner_filter)
        return _out(st, store.counts(s, [st.id])[st.id], store.study_jobs(s, st.id))

    return await db.read(fn, missing="study")


@router.get("/{study_id}/views", responses=ERRORS)
async def study_views(study_id: StudyId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The study's plots for its page: one chart per reported metric (median and range per
    group) and the panels the base's kind draws from the points (app/studies/views.py)."""
    from app.studies.views import study_views as views

    def fn(s):
        st = store.get_study(s, study_id, who.owner_filter)
        jobs = store.study_jobs(s, st.id)
        return {"panels": views(st.spec, store.point_rows(st, jobs), store.study_aggregate(st, jobs))}

    return await db.read(fn, missing="study")


@router.post("/{study_id}/cancel", status_code=202, responses=ERRORS)
async def cancel_study(study_id: StudyId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    def fn(s):
        st = store.cancel_study(s, study_id, who.owner_filter)
        s.flush()
        return _out(st, store.counts(s, [st.id])[st.id], store.study_jobs(s, st.id))

    return await db.write(fn, missing="study")


@router.get("/{study_id}/bundle", responses=ERRORS | {200: {"content": {"application/zip": {}}}})
async def study_bundle(study_id: StudyId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    def fn(s):
        st = store.get_study(s, study_id, who.owner_filter)
        jobs = store.study_jobs(s, st.id)
        rows = store.point_rows(st, jobs)
        return st.id, zip_bytes(study_files(st.spec, rows, store.study_aggregate(st, jobs), st.plan["infeasible"],
                                            {"study_id": st.id}))

    sid, data = await db.read(fn, missing="study")
    return Response(data, media_type="application/zip",
                    headers={"Content-Disposition": f'attachment; filename="study-{sid[:12]}.zip"'})

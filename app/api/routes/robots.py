"""/api/robots: the built-in robots and your own. POST uploads an MJCF legged robot
(multipart: the model and its asset files, or one zip); it goes through the defence of
app/robots/upload (pre-parse, confined compile, caps) and is stored sanitised
(app/store/robots.py). A robot belongs to its owner like a job: others get 404."""

from __future__ import annotations

import threading
import time
import uuid
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, Depends, Path as PathParam, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from app.api.auth import Principal, principal
from app.api.deps import Db, get_db, settings_of
from app.api.errors import ApiError
from app.api.routes.dashboard import LINK_TTL_S, _link_key, _link_principal, _link_token, _sign
from app.api.schemas import ERROR_RESPONSES, ErrorOut
from app.jobs.registry import KINDS, robots as builtin_robots, user_robot_kinds
from app.robots.upload import LIMITS, RefusedUpload, from_parts, from_zip, prepare
from app.store import robots as store

router = APIRouter(prefix="/robots", tags=["robots"])
ERRORS = ERROR_RESPONSES | {400: {"model": ErrorOut, "description": "a multipart body that cannot be parsed"}}
RobotId = Annotated[str, PathParam(min_length=1, max_length=64, description="robot id (or a built-in's name)")]
# An upload's body: the files' cap plus room for the multipart framing and the small fields.
MAX_BODY_BYTES = LIMITS.max_upload_bytes + 1024 * 1024
UPLOAD_SCHEMA = {"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {
    "type": "object",
    "properties": {
        "model": {"type": "string", "format": "binary", "description": "the MJCF file"},
        "assets": {"type": "array", "items": {"type": "string", "format": "binary"},
                   "description": "files the model references, each named by its path relative to the model"},
        "archive": {"type": "string", "format": "binary", "description": "instead of model and assets: one zip"},
        "model_path": {"type": "string", "description": "the model's path inside the zip"},
        "legs": {"type": "string", "description": "leg map JSON (default: detected from the model)"},
        "forward": {"type": "string", "enum": ["+x", "-x", "+y", "-y"]},
        "name": {"type": "string", "maxLength": 200},
    }}}}}}


def _builtins() -> list[dict]:
    out = []
    for name, entry in builtin_robots().items():
        info: dict = {}
        for k in entry["kinds"]:
            info |= KINDS[k].robot_info(name)
        out.append(info | {"name": name, "description": entry["description"], "kinds": entry["kinds"],
                           "builtin": True})
    return out


async def _who(request: Request) -> Principal | None:
    """The caller; None where tokens are required and none was sent (built-ins only)."""
    if request.app.state.auth_required and not request.headers.get("authorization"):
        return None
    return await principal(request)


@router.get("", responses=ERRORS)
async def list_robots(request: Request, db: Db = Depends(get_db)) -> list[dict]:
    """Every built-in robot with the kinds that simulate it, then your own robots with the
    kinds that run on an uploaded robot (a job names it by its `id`)."""
    who = await _who(request)
    own = []
    kinds = user_robot_kinds()
    if who is not None:
        rows = await db.read(lambda s: [store.as_dict(r, kinds) for r in store.list_robots(s, who.owner_filter)])
        own = [r | {"builtin": False, "description": f"uploaded MJCF robot, {len(r['legs']['legs'])} legs"}
               for r in rows]
    return _builtins() + own


@router.get("/{robot_id}", responses=ERRORS)
async def get_robot(robot_id: RobotId, who: Principal = Depends(principal), db: Db = Depends(get_db)) -> dict:
    """One robot: a built-in by name, or one of yours by id (its leg map, sizes, files)."""
    for r in _builtins():
        if r["name"] == robot_id:
            return r
    kinds = user_robot_kinds()
    return await db.read(lambda s: store.as_dict(store.get_robot(s, robot_id, who.owner_filter), kinds),
                         missing="robot")


@router.delete("/{robot_id}", status_code=204, responses=ERRORS)
async def delete_robot(robot_id: RobotId, request: Request, who: Principal = Depends(principal),
                       db: Db = Depends(get_db)) -> Response:
    """Delete one of your robots and its files; 409 while a queued or running job uses it."""
    if robot_id in builtin_robots():
        raise ApiError(409, f"{robot_id!r} is a built-in robot; it cannot be deleted", field="id")
    data_dir = settings_of(request).data_dir
    await db.write(lambda s: store.delete_robot(s, data_dir, robot_id, who.owner_filter), missing="robot")
    return Response(status_code=204)


async def _body(request: Request) -> bytes:
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype != "multipart/form-data":
        raise ApiError(415, f"Content-Type must be multipart/form-data, got {ctype or 'none'!r}", field="Content-Type")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > MAX_BODY_BYTES:
            raise ApiError(413, f"an upload is at most {LIMITS.max_upload_bytes} bytes of files", field="body")
        chunks.append(chunk)
    return b"".join(chunks)


async def _form(request: Request, body: bytes):
    async def receive():
        return {"type": "http.request", "body": body, "more_body": False}

    replay = Request(request.scope, receive)
    return await replay.form(max_files=LIMITS.max_files + 2, max_fields=16, max_part_size=256 * 1024)


def _text(form, key: str) -> str | None:
    v = form.get(key)
    if v is None or isinstance(v, str):
        return v
    raise ApiError(422, f"{key} must be a text field", field=key)


async def _upload(form):
    archive, model = form.get("archive"), form.get("model")
    assets = form.getlist("assets")
    if isinstance(archive, UploadFile):
        if model is not None or assets:
            raise RefusedUpload("send either archive (a zip) or model and assets, not both", field="archive")
        return from_zip(await archive.read(), _text(form, "model_path"))
    if not isinstance(model, UploadFile):
        raise RefusedUpload("the upload needs a model file (field model) or a zip (field archive)", field="model")
    parts = []
    for a in assets:
        if not isinstance(a, UploadFile):
            raise RefusedUpload("assets must be files", field="assets")
        parts.append((a.filename or "", await a.read()))
    return from_parts(model.filename or "model.xml", await model.read(), parts)


@router.post("", status_code=201, openapi_extra=UPLOAD_SCHEMA, responses=ERRORS | {200: {"description": "the same content was stored before: that robot"}})
async def add_robot(request: Request, response: Response, who: Principal = Depends(principal),
                    db: Db = Depends(get_db), check: bool = Query(False, description=(
                        "only check: the same checks and compile, nothing stored; 200 with the leg map (detected "
                        "unless given), its points and the model's sizes, for the dashboard to confirm"))) -> dict:
    """Upload an MJCF legged robot: checked, compiled in a confined process, stored
    sanitised with its leg map (detected unless `legs` is given: confirm it). 201 with the
    robot; 200 with the stored one when you uploaded the same content before; 4xx naming
    what was refused, with nothing stored. With `?check=true` nothing is stored either way."""
    t0 = time.perf_counter()
    form = await _form(request, await _body(request))
    try:
        upload = await _upload(form)
        legs = form.get("legs")
        legs = await legs.read() if isinstance(legs, UploadFile) else legs
        prepared = await run_in_threadpool(prepare, upload, legs, _text(form, "forward"), _text(form, "name"))
    except RefusedUpload as e:
        raise ApiError(e.status, f"refused: {e}", field=e.field) from None
    finally:
        await form.close()
    if check:
        response.status_code = 200
        return {"name": prepared.name, "legs": prepared.legs.to_json(), "detected": prepared.detected,
                "points": prepared.points, "stats": prepared.stats, "content_hash": prepared.content_hash,
                "stored": False, "seconds": round(time.perf_counter() - t0, 3)}
    data_dir = settings_of(request).data_dir
    info = {"detected": prepared.detected, "points": prepared.points, "stats": prepared.stats,
            "sandbox": prepared.sandbox}
    owner = who.name

    def write(s):
        row, created = store.add_robot(s, data_dir, owner=owner, name=prepared.name, content_hash=prepared.content_hash,
                                       legs=prepared.legs.to_json(), info=info, xml=prepared.xml,
                                       assets=prepared.assets)
        return store.as_dict(row, user_robot_kinds()), created

    out, created = await db.write(write, missing="robot")
    if not created:
        response.status_code = 200
    return out | {"builtin": False, "created": created, "seconds": round(time.perf_counter() - t0, 3)}


# -- 3D preview --------------------------------------------------------------------------------
# viser's client plays a .viser recording fetched by a plain GET (?playbackPath=), so the
# page asks (with its token) for a link signed for this robot, as the job page does for a
# bundle's replay.viser. The recording is made once from the stored, sanitised model (the one
# a job simulates; it passed the caps and the confined compile at upload) and kept beside it.
PREVIEW = "preview.viser"
PREVIEW_GATE = threading.BoundedSemaphore(2)  # at most two recordings made at once (each compiles the model)


def _preview_bytes(data_dir: Path, robot_id: str, robot) -> bytes:
    """The robot at its reference pose, its geoms and meshes as viser draws a replay."""
    import numpy as np

    from app.results.replay import record

    path = store.robot_dir(data_dir, robot_id) / PREVIEW
    if path.is_file():
        return path.read_bytes()
    with PREVIEW_GATE:
        model = robot.model()
        qpos = np.stack([model.qpos0, model.qpos0])
        data = record(model, {robot.name: {"qpos": qpos, "time_s": np.array([0.0, 0.04])}}, fps=25.0)
    tmp = path.with_name(f".{uuid.uuid4().hex}-{PREVIEW}")
    tmp.write_bytes(data)
    tmp.replace(path)  # a reader sees the whole file or none
    return data


@router.get("/{robot_id}/preview-link", responses=ERRORS)
async def preview_link(robot_id: RobotId, request: Request, who: Principal = Depends(principal),
                       db: Db = Depends(get_db)) -> dict:
    """A link to the robot's 3D preview (a .viser recording) that works without the
    Authorization header for an hour: viser's client opens it with `/viser/?playbackPath=`."""
    await db.read(lambda s: store.get_robot(s, robot_id, who.owner_filter).id, missing="robot")
    exp, tid = int(time.time()) + LINK_TTL_S, who.token_id or 0
    sig = _sign(_link_key(request), f"robot/{robot_id}", PREVIEW, exp, tid)
    return {"url": f"/api/robots/{robot_id}/{PREVIEW}?exp={exp}&sig={tid}.{sig}", "expires_at": exp}


@router.get(f"/{{robot_id}}/{PREVIEW}", responses=ERRORS | {200: {"content": {"application/octet-stream": {}}}})
async def preview(robot_id: RobotId, request: Request, exp: str | None = None, sig: str | None = None,
                  db: Db = Depends(get_db)) -> Response:
    """The robot's 3D preview: a .viser scene recording of the stored model at its
    reference pose. Authorised like the other robot routes, or by a link from /preview-link."""
    token = _link_token(_link_key(request), f"robot/{robot_id}", PREVIEW, exp, sig)
    who = await _link_principal(db, token) or await principal(request)
    data_dir = settings_of(request).data_dir
    robot = await db.read(lambda s: store.load_robot(s, data_dir, robot_id, who.owner_filter), missing="robot")
    data = await run_in_threadpool(_preview_bytes, data_dir, robot_id, robot)
    return Response(data, media_type="application/octet-stream", headers={"Cache-Control": "private, max-age=3600"})

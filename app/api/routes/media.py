"""/api/jobs/{id}/video and /thumbnail: the recovered gait and its baseline as an MP4, and
a small looping WebP of the gait for lists. Each is rendered on its first request (in a
child process: MuJoCo's offscreen renderer on software OpenGL, app/results/video.py) and
kept in the job's bundle zip (media/walk.mp4, media/thumbnail.webp), so a later request,
the bundle's download and the bundle's retention and deletion all include it."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, Depends, Path as PathParam, Response
from fastapi.concurrency import run_in_threadpool

from app.api.auth import Principal, principal
from app.api.deps import Db, get_db
from app.api.errors import ApiError
from app.api.schemas import ERROR_RESPONSES
from app.results.video import FPS, HEIGHT, MEDIA, THUMB_HEIGHT, THUMB_WIDTH, WIDTH, member
from app.store import repo

router = APIRouter(prefix="/jobs", tags=["jobs"])
JobId = Annotated[str, PathParam(min_length=1, max_length=64, description="job id")]
RENDER_TIMEOUT_S = 1800.0  # a long walk at 720p on two software-rendering cores
_SYNC: dict[int, tuple[asyncio.Semaphore, dict[str, asyncio.Lock]]] = {}


def _sync() -> tuple[asyncio.Semaphore, dict[str, asyncio.Lock]]:
    """(one render at a time: each keeps the CPU busy; a lock per bundle and medium), for
    the running event loop (asyncio's primitives belong to one loop)."""
    return _SYNC.setdefault(id(asyncio.get_running_loop()), (asyncio.Semaphore(1), {}))


async def _bundle_of(job_id: str, who: Principal, db: Db) -> tuple[str, Path]:
    job = await db.read(lambda s: repo.get_job(s, job_id, who.owner_filter))
    if job.status == "succeeded" and not job.bundle_path:
        raise ApiError(410, "the bundle was deleted by the retention policy (GAITMEND_BUNDLE_RETENTION_DAYS)")
    if job.status != "succeeded" or not job.bundle_path:
        raise ApiError(409, f"a video exists once the job succeeded; it is {job.status}", field="status")
    path = Path(job.bundle_path)
    if not path.is_file():
        raise ApiError(410, f"the bundle file is gone from the data folder: {path.name}")
    return job.id, path


async def _render(path: Path, what: str) -> bytes:
    name, _ = MEDIA[what]
    data = await run_in_threadpool(member, path, name)
    if data is not None:
        return data
    renders, locks = _sync()
    async with locks.setdefault(f"{path}:{what}", asyncio.Lock()), renders:  # a second request for the same job waits for the first render
        data = await run_in_threadpool(member, path, name)
        if data is not None:
            return data
        proc = await asyncio.create_subprocess_exec(sys.executable, "-m", "app.results.video", str(path), what,
                                                    stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE)
        try:
            _, err = await asyncio.wait_for(proc.communicate(), RENDER_TIMEOUT_S)
        except asyncio.TimeoutError:
            proc.kill()
            raise ApiError(503, f"rendering the {what} took longer than {RENDER_TIMEOUT_S:.0f} s") from None
    text = err.decode(errors="replace").strip().splitlines()
    if proc.returncode == 3:
        raise ApiError(409, f"this job has no {what}: {text[-1] if text else 'nothing to render'}", field="bundle")
    if proc.returncode != 0:
        raise ApiError(500, f"rendering the {what} failed: {text[-1] if text else proc.returncode}")
    return await run_in_threadpool(member, path, name)


@router.get("/{job_id}/video", responses=ERROR_RESPONSES | {200: {"content": {"video/mp4": {}}, "description":
            f"H.264 MP4, {WIDTH}x{HEIGHT} at {FPS} frames per second: the recovered gait beside its baseline, "
            "captioned with the damage, the target and the distance"}})
async def video(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """The job's video, rendered on the first request (seconds to minutes) and kept with
    its bundle (media/walk.mp4)."""
    jid, path = await _bundle_of(job_id, who, db)
    data = await _render(path, "video")
    return Response(data, media_type="video/mp4",
                    headers={"Content-Disposition": f'attachment; filename="gaitmend-{jid}.mp4"'})


@router.get("/{job_id}/thumbnail", responses=ERROR_RESPONSES | {200: {"content": {"image/webp": {}}, "description":
            f"animated WebP, {THUMB_WIDTH}x{THUMB_HEIGHT}, looping: the first trace's walk in a few seconds"}})
async def thumbnail(job_id: JobId, who: Principal = Depends(principal), db: Db = Depends(get_db)):
    """A small animated picture of the job's gait (for lists), rendered on the first
    request and kept with its bundle (media/thumbnail.webp)."""
    _, path = await _bundle_of(job_id, who, db)
    data = await _render(path, "thumbnail")
    return Response(data, media_type="image/webp", headers={"Cache-Control": "private, max-age=86400"})

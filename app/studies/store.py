"""Studies in the database: created with all their jobs in one transaction; progress,
status and the aggregate are read back from the jobs table (the one source of truth)."""

from __future__ import annotations

import uuid
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.store import repo
from app.store.models import FINAL, Job, Study, utcnow
from app.studies.aggregate import aggregate
from app.studies.spec import Plan


def create_study(s: Session, plan: Plan, *, owner: str, max_attempts: int, max_queued: int,
                 redispatch_after_s: float = 30.0, window_: int = 2) -> tuple[Study, list[str]]:
    """The study row and one job per point, in the caller's transaction; returns the ids to
    send now. Any number of points is accepted: the points are held and admitted to the
    owner's queue gradually, within the owner's limit (app/studies/fair.py feed), so a
    study never makes the owner's queue exceed GAITMEND_MAX_QUEUED_PER_OWNER.
    (`redispatch_after_s` is accepted for the callers' sake; a new study has no stale message.)"""
    from app.studies.fair import feed, select_fair

    repo.lock_owner(s, owner)
    study = Study(id=uuid.uuid4().hex, owner=owner, name=plan.study.name,
                  spec=plan.study.model_dump(mode="json", exclude_none=True),
                  plan={"overrides": [p["overrides"] for p in plan.points], "infeasible": plan.infeasible}, points=len(plan.points), cancel_requested=False,
                  created_at=utcnow())
    s.add(study)
    s.flush()
    ids = []
    now = utcnow()
    for p in plan.points:
        job = repo.create_job(s, owner=owner, kind=p["kind"], robot=p["robot"], spec=p["spec"],
                              evaluations_budget=p["budget"], max_attempts=max_attempts, held=True)
        job.study_id, job.study_point = study.id, p["index"]
        ids.append(job.id)
    s.flush()
    feed(s, max_queued, owner=owner)
    # Only the owner's fair share goes to the broker now; the rest wait unsent (app/studies/fair.py).
    mine = set(ids)
    ids = [i for i in select_fair(s, window_) if i in mine]
    repo.mark_dispatched(s, ids, now)
    return study, ids


def get_study(s: Session, study_id: str, owner: str | None) -> Study:
    q = select(Study).where(Study.id == study_id)
    if owner is not None:
        q = q.where(Study.owner == owner)
    st = s.scalar(q)
    if st is None:
        raise repo.NotFound(study_id)
    return st


def list_studies(s: Session, owner: str | None, limit: int = 50) -> list[Study]:
    q = select(Study)
    if owner is not None:
        q = q.where(Study.owner == owner)
    return list(s.scalars(q.order_by(Study.seq.desc()).limit(limit)))


def study_jobs(s: Session, study_id: str) -> list[Job]:
    return list(s.scalars(select(Job).where(Job.study_id == study_id).order_by(Job.study_point)))


def counts(s: Session, study_ids: list[str]) -> dict[str, dict[str, int]]:
    out: dict[str, dict[str, int]] = {i: {} for i in study_ids}
    if study_ids:
        q = select(Job.study_id, Job.status, func.count()).where(Job.study_id.in_(study_ids)).group_by(Job.study_id, Job.status)
        for sid, status, n in s.execute(q):
            out[sid][status] = n
    return out


def status_of(c: dict[str, int]) -> str:
    """running while any point is unfinished; then cancelled (if a point was), failed (if
    any point failed) or succeeded. A cancel asked for after every point had finished
    cancelled nothing: the study reads as what its points did ("3 of 3 done" is never
    "cancelled"), so the study's cancel flag does not enter it."""
    if c.get("queued", 0) + c.get("running", 0):
        return "running" if c.get("running", 0) or c.get("succeeded", 0) or c.get("failed", 0) else "queued"
    if c.get("cancelled", 0):
        return "cancelled"
    return "failed" if c.get("failed", 0) else "succeeded"


def progress(c: dict[str, int], total: int) -> dict[str, int]:
    return {"points": total, "done": c.get("succeeded", 0), "running": c.get("running", 0),
            "queued": c.get("queued", 0), "failed": c.get("failed", 0), "cancelled": c.get("cancelled", 0)}


def point_rows(study: Study, jobs: list[Job]) -> list[dict[str, Any]]:
    overrides = study.plan["overrides"]
    return [{"index": j.study_point, "overrides": overrides[j.study_point], "spec": j.spec,
             "status": j.status, "summary": j.summary, "error": j.error, "job_id": j.id} for j in jobs]


def study_aggregate(study: Study, jobs: list[Job]) -> dict[str, Any]:
    rep = study.spec["report"]
    return aggregate(point_rows(study, jobs), rep.get("group_by", []), rep["metrics"])


def cancel_study(s: Session, study_id: str, owner: str | None) -> Study:
    """Cancels every point that has not finished (queued now, running at its next unit)."""
    study = get_study(s, study_id, owner)
    study.cancel_requested = True
    for j in study_jobs(s, study_id):
        if j.status not in FINAL:
            repo.request_cancel(s, j.id, None)
    return study

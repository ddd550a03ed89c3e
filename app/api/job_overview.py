"""What the dashboard shows at a glance beside the API's job records (app/api/routes/
dashboard.py serves it): each job's verdict and list headline (the kind's ``verdict`` and
``list_headline``), seed, budget and study; and time before it is spent: the wall time a
spec will take, a queued job's place in the queue and every unfinished job's ETA.

Estimates come from this server's own measured throughput: for a kind, the median wall
seconds per evaluation of its last ``RECENT`` succeeded jobs (started to finished over the
evaluation budget). A kind with no finished job here has no estimate, and says so."""

from __future__ import annotations

import datetime as dt
import functools
import statistics
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.store import repo
from app.store.models import FINAL, Job, Study, utcnow

RECENT = 20
LIVE_WORKER_S = 120.0
CONFIRM_ABOVE_S = 600.0  # the form and the study page ask before queueing more than this


def _kind(name: str | None):
    from app.jobs.registry import KINDS

    return KINDS.get(name) if isinstance(name, str) else None


def _aware(t: dt.datetime | None) -> dt.datetime | None:
    return t.replace(tzinfo=dt.timezone.utc) if t is not None and t.tzinfo is None else t


# -- throughput ------------------------------------------------------------------------------------

def rates(s: Session) -> dict[str, dict[str, Any]]:
    """Per kind: median seconds per evaluation over its last RECENT succeeded jobs, and how many."""
    out: dict[str, dict[str, Any]] = {}
    kinds = s.scalars(select(Job.kind).where(Job.status == "succeeded").distinct())
    for kind in kinds:
        rows = s.execute(select(Job.started_at, Job.finished_at, Job.evaluations_budget)
                         .where(Job.kind == kind, Job.status == "succeeded", Job.started_at.is_not(None),
                                Job.finished_at.is_not(None), Job.evaluations_budget > 0)
                         .order_by(Job.seq.desc()).limit(RECENT)).all()
        per = [(_aware(f) - _aware(st)).total_seconds() / n for st, f, n in rows if f and st and n]
        if per:
            out[kind] = {"s_per_evaluation": statistics.median(per), "jobs": len(per)}
    return out


def rate_text(kind: str, rate: dict[str, dict[str, Any]]) -> str:
    r = rate.get(kind)
    if r is None:
        return f"no {kind} job has finished on this server yet: no measured rate to estimate from"
    return (f"{r['s_per_evaluation']:.3g} s per {kind} evaluation: the median of the last {r['jobs']} finished "
            f"{kind} job{'s' if r['jobs'] > 1 else ''} on this server (wall time over evaluation budget)")


def estimate(kind: str, evaluations: int, rate: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The wall time of ``evaluations`` of ``kind`` at this server's measured rate."""
    r = rate.get(kind)
    wall = None if r is None else evaluations * r["s_per_evaluation"]
    return {"wall_s": wall, "confirm": wall is not None and wall > CONFIRM_ABOVE_S, "confirm_above_s": CONFIRM_ABOVE_S,
            "basis": (f"{evaluations} evaluations x " if r else "") + rate_text(kind, rate)}


# -- the queue --------------------------------------------------------------------------------------

def _remaining(job: Job, rate: dict, now: dt.datetime) -> float | None:
    """Seconds a job still needs: from its own progress once under way, else the estimate."""
    est = estimate(job.kind, job.evaluations_budget, rate)["wall_s"]
    if job.status == "running" and job.started_at is not None:
        spent = (now - _aware(job.started_at)).total_seconds()
        frac = job.progress_done / job.progress_total if job.progress_total else 0.0
        if frac >= 0.02:
            return max(0.0, spent * (1 - frac) / frac)
        return None if est is None else max(0.0, est - spent)
    return est


def queue_info(s: Session, job: Job, rate: dict) -> dict[str, Any] | None:
    """A queued job's place (1 = next) and an unfinished job's ETA (seconds from now, None
    when some job ahead has no estimate)."""
    if job.status in FINAL:
        return None
    now = utcnow()
    own = _remaining(job, rate, now)
    if job.status == "running":
        return {"position": None, "eta_s": own, "ahead": 0,
                "how": "from its progress so far" if job.progress_total and job.progress_done else "from the estimate"}
    ahead = list(s.scalars(select(Job).where(Job.status == "queued", Job.held.is_(False), Job.seq < job.seq)))
    running = list(s.scalars(select(Job).where(Job.status == "running")))
    slots = max(1, repo.idle_slots(s, LIVE_WORKER_S)[0])
    waits = [_remaining(j, rate, now) for j in ahead + running]
    eta = None if own is None or any(w is None for w in waits) else sum(waits) / slots + own
    return {"position": len(ahead) + 1, "ahead": len(ahead), "running": len(running), "slots": slots, "eta_s": eta,
            "held": bool(job.held), "how": f"the jobs ahead and running, shared over {slots} worker slot(s), then this one"}


# -- the list's rows ----------------------------------------------------------------------------------

@functools.lru_cache(maxsize=2048)
def _finished_view(job_id: str, kind_name: str, finished: str, summary_json: str) -> dict[str, Any]:
    """Verdict and list headline of a succeeded job (cached: a finished summary never changes)."""
    import json

    from app.jobs.verdict import brief

    kind, summary = _kind(kind_name), json.loads(summary_json)
    try:
        v = kind.verdict(summary)
    except Exception:  # a summary stored by an older release: no verdict, the row still lists
        return {"headline": None, "verdict": None}
    return {"headline": v.get("primary"), "verdict": brief(v)}


def _seed(job: Job) -> int | None:
    kind = _kind(job.kind)
    try:
        return int(kind.Spec.parse(job.spec).seed)
    except Exception:  # a spec of an older release
        return None


def rows(s: Session, ids: list[str], owner: str | None) -> dict[str, dict[str, Any]]:
    """{job id: {seed, budget, study, headline, verdict, queue}} for the given ids the
    caller may see."""
    import json

    q = select(Job, Study.name).outerjoin(Study, Study.id == Job.study_id).where(Job.id.in_(ids))
    if owner is not None:
        q = q.where(Job.owner == owner)
    found = s.execute(q).all()
    rate = rates(s) if any(j.status not in FINAL for j, _ in found) else {}
    out = {}
    for job, study in found:
        row: dict[str, Any] = {"seed": _seed(job), "budget": job.evaluations_budget, "headline": None, "verdict": None,
                               "study": {"id": job.study_id, "name": study, "point": job.study_point} if job.study_id else None,
                               "queue": queue_info(s, job, rate)}
        if job.status == "succeeded" and job.summary and _kind(job.kind) is not None:
            row |= _finished_view(job.id, job.kind, str(job.finished_at), json.dumps(job.summary, sort_keys=True))
        out[job.id] = row
    return out


def study_estimate(s: Session, points: list[dict[str, Any]]) -> dict[str, Any]:
    """Size and wall time of a study's points (app/studies/spec.py Plan.points) at the
    measured rates, one worker slot after another and shared over the live slots."""
    rate = rates(s)
    walls = [estimate(p["kind"], p["budget"], rate)["wall_s"] for p in points]
    slots = max(1, repo.idle_slots(s, LIVE_WORKER_S)[0])
    total = None if any(w is None for w in walls) else sum(walls)
    kinds = sorted({p["kind"] for p in points})
    return {"points": len(points), "evaluations": sum(p["budget"] for p in points), "slots": slots,
            "wall_s": None if total is None else total / slots, "cpu_s": total,
            "confirm": total is None or total / slots > CONFIRM_ABOVE_S, "confirm_above_s": CONFIRM_ABOVE_S,
            "basis": "; ".join(rate_text(k, rate) for k in kinds)}

"""Adaptation sessions (issue 44) as rows: created over the owner's finished repertoire
jobs, one row a measured trial. Each function runs in the caller's transaction; a trial is
checked, written and the session's status moved in that one transaction, so a refused or
failed post writes nothing. The model is never stored: app/adapt/session.py recomputes it
from the trials (deterministic), so the rows are the whole state of a session."""

from __future__ import annotations

import re
import uuid
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from sqlalchemy import Text, cast, select
from sqlalchemy.orm import Session

from app.store.adaptation_models import AdaptationRow, AdaptationTrial
from app.store.models import Job, utcnow
from app.store.repo.jobs import Conflict, NotFound


if TYPE_CHECKING:
    from app.adapt import session as S


def _session():
    """app/adapt/session.py, imported when a session is first touched: it brings the Gaussian
    process (scikit-learn) and the kinds, which the store's other users never need."""
    from app.adapt import session

    return session


class Refused(ValueError):
    """A request the session's repertoires do not allow: ``status`` (404, 409, 410, 422) and
    the ``field`` at fault."""

    def __init__(self, status: int, field: str, message: str):
        super().__init__(message)
        self.status, self.field = status, field


def _sources(s: Session, ids: list[str], owner: str | None, creating: bool) -> list[S.MapSource]:
    """The jobs' states read without their results; each result is read only if the map
    is not already held (app/adapt/session.py ``load_maps``), as its stored JSON text."""
    S = _session()
    out = []
    for i, jid in enumerate(ids):
        field = f"repertoires.{i}"
        q = select(Job.seq, Job.id, Job.owner, Job.kind, Job.status, Job.finished_at,
                   Job.summary.is_(None).label("empty")).where(Job.id == jid)
        job = s.execute(q).one_or_none()
        if job is not None and creating and owner is not None and job.owner != owner:
            job = None
        if job is None and creating:  # another owner's job is missing, as everywhere
            raise Refused(404, field, f"no job {jid!r} of yours")
        if job is None:
            raise Refused(410, field, f"repertoire job {jid} was deleted; the session cannot go on")
        if job.kind != "repertoire":
            raise Refused(422, field, f"job {jid} is a {job.kind} job; a session adapts with repertoire jobs")
        if job.status != "succeeded" or job.empty:
            raise Refused(409, field, f"repertoire job {jid} is {job.status}; a session needs finished maps")
        out.append(S.MapSource(job.id, job.finished_at.isoformat() if job.finished_at else "",
                               lambda seq=job.seq: s.scalar(select(cast(Job.summary, Text)).where(Job.seq == seq))))
    return out


def _maps(s: Session, row_or_ids, owner: str | None = None, creating: bool = False):
    ids = row_or_ids if isinstance(row_or_ids, list) else row_or_ids.spec["repertoires"]
    from app.adapt.maps import MapError

    sources = _sources(s, ids, owner, creating)
    try:
        return _session().load_maps(sources), sources
    except MapError as e:  # its message names a temporary file: name the job instead
        msg = re.sub(r"\S*gaitmend-maps-[^/\s]*/(\d+)\.json", lambda m: f"repertoire job {ids[int(m.group(1))]}", str(e))
        raise Refused(422, "repertoires", msg) from None


def _target(row: AdaptationRow, reps) -> float | None:
    """The session's recovery target: fixed at its creation, else (a session created before
    the column) the built-in robot's."""
    return row.target_m_s if row.target_m_s is not None else _session().target_m_s(reps)


def create_adaptation(s: Session, spec: S.SessionSpec, *, owner: str, owner_filter: str | None,
                      robots: Callable[[str], Any] | None = None) -> AdaptationRow:
    """A new session over ``spec.repertoires`` (each a finished repertoire job the caller may
    see, the maps over one behaviour space); Refused naming the repertoire at fault. The
    recovery target is fixed here: a built-in robot's, or, where the first map's job ran on an
    uploaded robot, that robot's measured on its stored model (``robots``: its loader, id ->
    app/robots/legmap.py ``Robot``; a robot no longer stored leaves the target null)."""
    reps, _ = _maps(s, list(spec.repertoires), owner_filter, creating=True)
    stored = None
    robot_id = s.scalar(select(Job.robot).where(Job.id == spec.repertoires[0]))
    if robots is not None and robot_id and robot_id != reps[0].robot:  # the map names an uploaded robot by name
        try:
            stored = robots(robot_id)
        except NotFound:
            stored = None
    target = _session().target_m_s(reps, stored) if stored is not None or robot_id == reps[0].robot else None
    row = AdaptationRow(id=uuid.uuid4().hex, owner=owner, spec=spec.model_dump(mode="json"), status="open",
                        stop_reason=None, trials=0, target_m_s=target)
    s.add(row)
    s.flush()
    return row


def get_adaptation(s: Session, adaptation_id: str, owner: str | None = None, lock: bool = False) -> AdaptationRow:
    """A session by id; someone else's is NotFound, like a missing one. ``lock``: held until
    the transaction ends (PostgreSQL; SQLite's write transaction locks the database)."""
    q = select(AdaptationRow).where(AdaptationRow.id == adaptation_id)
    if owner is not None:
        q = q.where(AdaptationRow.owner == owner)
    if lock:
        q = q.with_for_update()
    row = s.scalar(q)
    if row is None:
        raise NotFound(adaptation_id)
    return row


def list_adaptations(s: Session, owner: str | None = None, limit: int = 50) -> list[AdaptationRow]:
    q = select(AdaptationRow).order_by(AdaptationRow.seq.desc()).limit(limit)
    if owner is not None:
        q = q.where(AdaptationRow.owner == owner)
    return list(s.scalars(q))


def trial_rows(s: Session, row: AdaptationRow) -> list[AdaptationTrial]:
    return list(s.scalars(select(AdaptationTrial).where(AdaptationTrial.adaptation_seq == row.seq)
                          .order_by(AdaptationTrial.index)))


def _stored(rows: list[AdaptationTrial]) -> list[S.StoredTrial]:
    S = _session()
    return [S.StoredTrial(r.index, r.map, r.elite, r.forward_m, r.lateral_m, r.yaw_deg, r.fell, r.duration_s)
            for r in rows]


def post_trial(s: Session, adaptation_id: str, t: S.TrialIn, owner: str | None = None) -> AdaptationRow:
    """Trial ``t.trial`` of the session, measured on the gait the session proposes for it:
    stored with that proposal, and the session finished when the stop rule says so.
    Conflict (nothing written) for a number already stored (field ``trial``), one that is
    not the next, or a finished session (field ``status``)."""
    S = _session()
    row = get_adaptation(s, adaptation_id, owner, lock=True)
    if t.trial <= row.trials:
        raise Conflict(f"trial {t.trial} is already stored (the session has {row.trials}); a trial is posted "
                       "once", field="trial")
    if row.status != "open":
        raise Conflict(f"the session is finished ({row.stop_reason}); it takes no more trials", field="status")
    if t.trial != row.trials + 1:
        raise Conflict(f"trial {t.trial} cannot come yet: the session has {row.trials} trials, so the next is "
                       f"trial {row.trials + 1}", field="trial")
    spec = S.SessionSpec.model_validate(row.spec)
    reps, _ = _maps(s, row)
    rows = trial_rows(s, row)
    before = S.step(reps, spec, _stored(rows))
    if before.proposal is None:  # stopped without its status saying so: never expected, refused rather than stored
        raise Conflict(f"the session is finished ({before.decision.reason})", field="status")
    p = before.proposal
    new = AdaptationTrial(adaptation_seq=row.seq, index=t.trial, map=p.map, elite=p.elite, forward_m=t.forward_m,
                          lateral_m=t.lateral_m, yaw_deg=t.yaw_deg, fell=t.fell, duration_s=t.duration_s, note=t.note,
                          proposal=S.proposal_json(reps, spec, p, t.trial))
    s.add(new)
    after = S.step(reps, spec, [*_stored(rows), *_stored([new])])
    row.trials = t.trial
    row.updated_at = utcnow()
    if after.decision.stop:
        row.status, row.stop_reason = "finished", after.decision.reason
    s.flush()
    return row


def adaptation_json(s: Session, row: AdaptationRow, detail: bool = True) -> dict:
    """The session as the API shows it: its spec, trials in order with their measurements,
    the stop decision and why, and the gait to run next (null once finished)."""
    S = _session()
    out = {"id": row.id, "name": row.spec.get("name", ""), "owner": row.owner, "status": row.status,
           "method": row.spec["method"], "trials_done": row.trials, "stop_reason": row.stop_reason,
           "created_at": row.created_at.isoformat(), "updated_at": row.updated_at.isoformat(),
           "links": {"self": f"/api/adaptations/{row.id}", "trials": f"/api/adaptations/{row.id}/trials",
                     "page": f"/adaptations/{row.id}",
                     "next_bundle": f"/api/adaptations/{row.id}/proposals/{row.trials + 1}/bundle"}}
    if not detail:
        return out
    spec = S.SessionSpec.model_validate(row.spec)
    reps, _ = _maps(s, row)
    rows = trial_rows(s, row)
    st = S.step(reps, spec, _stored(rows))
    target = _target(row, reps)
    out |= {"spec": row.spec, "trial_s": S.trial_s(reps, spec), "target_m_s": target,
            "maps": [{"name": r.map.name, "job": r.source, "elites": len(r.cells), "robot": r.robot,
                      "damage": r.damage} for r in reps],
            "trials": [trial_json(r, spec, target) for r in rows],
            "decision": S.decision_json(st.decision),
            "next": None if st.proposal is None else S.proposal_json(reps, spec, st.proposal, row.trials + 1)}
    return out


def trial_json(r: AdaptationTrial, spec: S.SessionSpec, target: float | None) -> dict:
    S = _session()
    m = S.settings_of(spec)
    perf = S.StoredTrial(r.index, r.map, r.elite, r.forward_m, r.lateral_m, r.yaw_deg, r.fell, r.duration_s) \
        .trial().performance(m.straight, m.falls)
    speed = r.forward_m / r.duration_s
    return {"trial": r.index, "map": r.map, "elite": r.elite, "cell": r.proposal.get("cell"),
            "forward_m": r.forward_m, "lateral_m": r.lateral_m, "yaw_deg": r.yaw_deg, "fell": r.fell,
            "duration_s": r.duration_s, "note": r.note, "speed_m_s": speed, "performance_m_s": perf,
            "predicted_m_s": r.proposal.get("predicted_m_s"),
            "recovered": None if target is None else bool(not r.fell and speed >= target),
            "created_at": r.created_at.isoformat()}


def trials_json(s: Session, adaptation_id: str, owner: str | None = None) -> list[dict]:
    S = _session()
    row = get_adaptation(s, adaptation_id, owner)
    spec = S.SessionSpec.model_validate(row.spec)
    reps, _ = _maps(s, row)
    return [trial_json(r, spec, _target(row, reps)) for r in trial_rows(s, row)]


def proposal_bundle(s: Session, adaptation_id: str, index: int, owner: str | None = None) -> dict[str, bytes]:
    """The files of the gait proposed for trial ``index``: a stored trial's proposal, or the
    next one while the session is open (Refused 404 naming ``trial`` otherwise)."""
    S = _session()
    row = get_adaptation(s, adaptation_id, owner)
    spec = S.SessionSpec.model_validate(row.spec)
    reps, sources = _maps(s, row)
    rows = trial_rows(s, row)
    if 1 <= index <= len(rows):
        prop = rows[index - 1].proposal
    elif index == len(rows) + 1 and (st := S.step(reps, spec, _stored(rows))).proposal is not None:
        prop = S.proposal_json(reps, spec, st.proposal, index)
    else:
        raise Refused(404, "trial", f"no proposal for trial {index}: the session has {len(rows)} trials and is "
                                    f"{row.status}")
    summary = next(src.summary for src in sources if src.job_id == prop["job"])
    return S.proposal_files(summary, prop, row.id)


def session_state(s: Session, row: AdaptationRow):
    """(maps, spec, stored trials, step) of a session: what its page plots."""
    S = _session()
    spec = S.SessionSpec.model_validate(row.spec)
    reps, _ = _maps(s, row)
    trials = _stored(trial_rows(s, row))
    return reps, spec, trials, S.step(reps, spec, trials)

"""Repository functions for uploaded robots, and their files under <data_dir>/robots/<id>/
(model.xml and assets/<name>). A robot is immutable: the same owner storing the same
content again gets the stored robot back; a changed model is a new robot. Someone else's
robot is NotFound, like a missing one; deleting one that a queued or running job names is
a Conflict."""

from __future__ import annotations

import json
import shutil
import uuid
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.store.models import FINAL, Job
from app.store.repo import Conflict, NotFound
from app.store.robot_models import RobotRow

MODEL_FILE = "model.xml"


def robot_dir(data_dir: Path, robot_id: str) -> Path:
    return Path(data_dir) / "robots" / robot_id


def _write_files(folder: Path, xml: str, assets: dict[str, bytes]) -> None:
    """Into a fresh folder beside the final one, then renamed: a robot's folder is whole or absent."""
    tmp = folder.with_name(f".incoming-{folder.name}")
    shutil.rmtree(tmp, ignore_errors=True)
    (tmp / "assets").mkdir(parents=True)
    (tmp / MODEL_FILE).write_text(xml, encoding="utf-8")
    for name, data in assets.items():
        path = (tmp / "assets" / name).resolve()
        if not path.is_relative_to((tmp / "assets").resolve()):  # names were normalised; this is the backstop
            raise ValueError(f"asset name {name!r} leaves the robot's folder")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    tmp.rename(folder)


def find_by_hash(s: Session, owner: str, content_hash: str) -> RobotRow | None:
    return s.scalar(select(RobotRow).where(RobotRow.owner == owner, RobotRow.content_hash == content_hash))


def add_robot(s: Session, data_dir: Path, *, owner: str, name: str, content_hash: str, legs: dict, info: dict,
              xml: str, assets: dict[str, bytes]) -> tuple[RobotRow, bool]:
    """(robot, created). Files are written before the row; a failed insert removes them."""
    found = find_by_hash(s, owner, content_hash)
    if found is not None:
        return found, False
    robot_id = uuid.uuid4().hex
    folder = robot_dir(data_dir, robot_id)
    folder.parent.mkdir(parents=True, exist_ok=True)
    _write_files(folder, xml, assets)
    info = dict(info) | {"files": sorted(assets), "model_bytes": len(xml.encode())}
    row = RobotRow(id=robot_id, owner=owner, content_hash=content_hash, name=name, legs=legs, info=info)
    try:
        with s.begin_nested():
            s.add(row)
            s.flush()
    except IntegrityError:
        shutil.rmtree(folder, ignore_errors=True)
        found = find_by_hash(s, owner, content_hash)  # stored meanwhile by a concurrent request
        if found is None:
            raise
        return found, False
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return row, True


def get_robot(s: Session, robot_id: str, owner: str | None = None) -> RobotRow:
    q = select(RobotRow).where(RobotRow.id == robot_id)
    if owner is not None:
        q = q.where(RobotRow.owner == owner)
    row = s.scalar(q)
    if row is None:
        raise NotFound(robot_id)
    return row


def list_robots(s: Session, owner: str | None = None, limit: int = 500) -> list[RobotRow]:
    q = select(RobotRow).order_by(RobotRow.seq)
    if owner is not None:
        q = q.where(RobotRow.owner == owner)
    return list(s.scalars(q.limit(limit)))


def jobs_using(s: Session, robot_id: str) -> list[str]:
    """Ids of queued or running jobs that name the robot."""
    q = select(Job.id).where(Job.robot == robot_id, Job.status.not_in(FINAL)).limit(10)
    return list(s.scalars(q))


def delete_robot(s: Session, data_dir: Path, robot_id: str, owner: str | None = None) -> None:
    row = get_robot(s, robot_id, owner)
    users = jobs_using(s, row.id)
    if users:
        raise Conflict(f"robot {row.id} is used by {len(users)} queued or running job(s): {', '.join(users)}; "
                       "cancel them or wait for them to finish", field="id")
    s.delete(row)
    s.flush()
    shutil.rmtree(robot_dir(data_dir, row.id), ignore_errors=True)


def read_files(data_dir: Path, robot_id: str, names: list[str]) -> tuple[str, dict[str, bytes]]:
    """The stored (sanitised) model and its assets."""
    folder = robot_dir(data_dir, robot_id)
    xml = (folder / MODEL_FILE).read_text(encoding="utf-8")
    return xml, {n: (folder / "assets" / n).read_bytes() for n in names}


def load_robot(s: Session, data_dir: Path, robot_id: str, owner: str | None = None):
    """The stored robot as a job runs it (app/robots/legmap.py ``Robot``): the sanitised
    model, its assets and its leg map. NotFound for a missing one (or another owner's)."""
    from app.robots.legmap import LegMap, Robot

    row = get_robot(s, robot_id, owner)
    xml, assets = read_files(data_dir, row.id, list(row.info.get("files", [])))
    return Robot(name=row.name, mjcf=xml, assets=assets, legs=LegMap.parse(row.legs))


def as_dict(row: RobotRow, kinds: list[str] | tuple[str, ...] = ()) -> dict:
    """The robot as the API and the CLI show it; ``kinds``: the job kinds that run on an
    uploaded robot (the registry's, which the store does not import)."""
    return {"id": row.id, "name": row.name, "owner": row.owner, "content_hash": row.content_hash,
            "created_at": row.created_at.isoformat(), "legs": row.legs,
            "detected": bool(row.info.get("detected")), "stats": row.info.get("stats", {}),
            "points": row.info.get("points", {}), "files": row.info.get("files", []),
            "kinds": list(kinds)}


def dumps(row: RobotRow, kinds: list[str] | tuple[str, ...] = ()) -> str:
    return json.dumps(as_dict(row, kinds))

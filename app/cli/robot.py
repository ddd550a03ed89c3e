"""`gaitmend robot add|list|show|delete`: robots uploaded into this machine's gaitmend
database and data folder (GAITMEND_DATA_DIR / GAITMEND_DATABASE_URL; owner "local", the
owner of everything without API tokens). The model goes through the same defence as
POST /api/robots (app/robots/upload); a refused upload exits 2 with the reason."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Optional

import typer

from app.cli.common import cli, err, fail, settings_or_exit

robot_app = typer.Typer(no_args_is_help=True, help="Your robots: upload an MJCF legged robot, list, delete.")
cli.add_typer(robot_app, name="robot")
OWNER = "local"


def _database(settings) -> None:
    from app.store.migrate import at_head, upgrade

    settings.data_dir.mkdir(parents=True, exist_ok=True)
    try:
        if not at_head(settings.db_url):
            upgrade(settings.db_url)
    except Exception as e:  # noqa: BLE001  (an unreachable server: say which)
        fail(f"cannot open the database {settings.db_url.split('@')[-1]}: {type(e).__name__}: {e}", code=1)


def _legs_text(legs: dict) -> str:
    rows = [f"  {l['name']:16s} {l['side']:5s} #{l['order']}  joints {', '.join(l['joints'])}  "
            f"foot {l['foot']['kind']} {l['foot']['name']}" for l in legs["legs"]]
    return f"trunk {legs['trunk']}, forward {legs['forward']}\n" + "\n".join(rows)


def load_local_robot(robot_id: str):
    """A robot stored here (owner "local"), as a job runs it: `gaitmend run` / `verify`."""
    from app.jobs.base import SpecError
    from app.store import repo, robots as store
    from app.store.db import session_scope

    settings = settings_or_exit()
    _database(settings)
    try:
        with session_scope(settings.db_url, readonly=True) as s:
            return store.load_robot(s, settings.data_dir, robot_id, OWNER)
    except repo.NotFound:
        raise SpecError([{"field": "robot", "message": f"no robot {robot_id!r} stored here "
                                                       "(gaitmend robot list)"}]) from None


def _kinds() -> list[str]:
    from app.jobs.registry import user_robot_kinds

    return user_robot_kinds()


@robot_app.command("add")
def robot_add(model: Path = typer.Argument(..., help="the MJCF file (or a .zip holding it and its assets)"),
              assets: Optional[Path] = typer.Option(None, "--assets", help="folder of the files the model references "
                                                    "(meshes, textures, included XML), by their relative names"),
              legs: Optional[Path] = typer.Option(None, "--legs", help="leg map JSON (default: detected from the model)"),
              forward: Optional[str] = typer.Option(None, "--forward", help="trunk axis pointing forward for "
                                                    "detection: +x, -x, +y or -y"),
              name: Optional[str] = typer.Option(None, "--name", help="a name to show (default: the file's)"),
              model_path: Optional[str] = typer.Option(None, "--model-path", help="the model's path inside the zip"),
              as_json: bool = typer.Option(False, "--json", help="print the stored robot as one JSON object")):
    """Check, compile (in a confined process) and store a robot; print its id and legs."""
    from app.robots.upload import RefusedUpload, from_dir, from_zip, prepare
    from app.store import robots as store
    from app.store.db import session_scope

    settings = settings_or_exit()
    t0 = time.perf_counter()
    try:
        if not model.is_file():
            fail(f"model file not found: {model}")
        if assets is not None and not assets.is_dir():
            fail(f"--assets must be a folder: {assets}")
        upload = (from_zip(model.read_bytes(), model_path) if model.suffix.lower() == ".zip"
                  else from_dir(model, assets))
        legs_text = legs.read_bytes() if legs is not None else None
        prepared = prepare(upload, legs=legs_text, forward=forward, name=name)
    except RefusedUpload as e:
        fail(f"refused: {e}")
    except OSError as e:
        fail(f"cannot read {e.filename}: {e.strerror}")
    _database(settings)
    info = {"detected": prepared.detected, "points": prepared.points, "stats": prepared.stats,
            "sandbox": prepared.sandbox}
    with session_scope(settings.db_url) as s:
        row, created = store.add_robot(s, settings.data_dir, owner=OWNER, name=prepared.name,
                                       content_hash=prepared.content_hash, legs=prepared.legs.to_json(), info=info,
                                       xml=prepared.xml, assets=prepared.assets)
        out = store.as_dict(row, _kinds())
    out["created"] = created
    seconds = time.perf_counter() - t0
    if as_json:
        print(json.dumps(out))
        return
    print(f"{'stored' if created else 'already stored'}: robot {out['id']} ({out['name']}) in {seconds:.2f} s")
    print(("legs detected from the model; check them:\n" if out["detected"] else "legs as given:\n")
          + _legs_text(out["legs"]))


@robot_app.command("list")
def robot_list(as_json: bool = typer.Option(False, "--json")):
    """Robots stored here."""
    from app.store import robots as store
    from app.store.db import session_scope

    settings = settings_or_exit()
    _database(settings)
    with session_scope(settings.db_url, readonly=True) as s:
        rows = [store.as_dict(r, _kinds()) for r in store.list_robots(s, OWNER)]
    if as_json:
        print(json.dumps(rows))
        return
    err.print(f"{len(rows)} robot{'' if len(rows) == 1 else 's'}", highlight=False)
    for r in rows:
        print(f"{r['id']}  {r['name']:24s} {len(r['legs']['legs'])} legs  {r['created_at']}")


@robot_app.command("show")
def robot_show(robot_id: str, as_json: bool = typer.Option(False, "--json")):
    """One robot: its leg map, sizes and files."""
    from app.store import repo, robots as store
    from app.store.db import session_scope

    settings = settings_or_exit()
    _database(settings)
    try:
        with session_scope(settings.db_url, readonly=True) as s:
            out = store.as_dict(store.get_robot(s, robot_id, OWNER), _kinds())
    except repo.NotFound:
        fail(f"no robot {robot_id!r}")
    print(json.dumps(out) if as_json else f"{out['id']}  {out['name']}\n" + _legs_text(out["legs"]))


@robot_app.command("delete")
def robot_delete(robot_id: str):
    """Delete a robot and its files; refused while a queued or running job uses it."""
    from app.store import repo, robots as store
    from app.store.db import session_scope

    settings = settings_or_exit()
    _database(settings)
    try:
        with session_scope(settings.db_url) as s:
            store.delete_robot(s, settings.data_dir, robot_id, OWNER)
    except repo.NotFound:
        fail(f"no robot {robot_id!r}")
    except repo.Conflict as e:
        fail(str(e))
    print(f"deleted robot {robot_id}")

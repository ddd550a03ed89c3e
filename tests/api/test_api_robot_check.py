"""/api/robots for the dashboard's Add robot page (issue 23): `?check=true` answers the leg
map it found (or the one sent, checked) and stores nothing, refusals included; the viser
preview of a stored robot is its owner's (others 404, no token 401) or a signed link's, and
a link signed for one robot opens no other."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from fastapi.testclient import TestClient
from service_support import deployment, migrated

sys.path.insert(0, str(Path(__file__).parents[1] / "robots"))
from legged_models import HEXAPOD_OTHER, build  # noqa: E402

from app.api import create_app  # noqa: E402
from app.store import repo  # noqa: E402
from app.store import robots as store  # noqa: E402
from app.store.db import session_scope  # noqa: E402


def _stored(settings) -> tuple[int, list]:
    with session_scope(settings.db_url, readonly=True) as s:
        n = len(store.list_robots(s))
    folder = settings.data_dir / "robots"
    return n, sorted(folder.iterdir()) if folder.exists() else []


def test_check_answers_the_legs_and_stores_nothing_then_the_preview_is_the_owners(tmp_path):
    settings = migrated(deployment(tmp_path))
    with session_scope(settings.db_url) as s:
        A, B = ({"Authorization": f"Bearer {repo.create_token(s, n)}"} for n in ("alice", "bob"))
    client = TestClient(create_app(settings, host="0.0.0.0"))
    model = {"model": ("hexapod_other.xml", build(HEXAPOD_OTHER).to_xml().encode(), "application/xml")}

    found = client.post("/api/robots?check=true", files=model, headers=A)
    assert found.status_code == 200, found.text
    body = found.json()
    assert body["stored"] is False and body["detected"] is True and "id" not in body
    assert sorted(leg["name"] for leg in body["legs"]["legs"]) == ["L0", "L1", "L2", "R0", "R1", "R2"]
    assert set(body["points"]) == {leg["name"] for leg in body["legs"]["legs"]}
    legs, joints = body["legs"], list(body["legs"]["legs"][0]["joints"])
    legs["legs"][0]["joints"] = joints[1:]  # not the path from the trunk: refused, named
    bad = client.post("/api/robots?check=true", files=model, data={"legs": json.dumps(legs)}, headers=A)
    assert bad.status_code == 422 and bad.json()["errors"][0]["field"] == "legs", bad.text
    assert _stored(settings) == (0, [])

    legs["legs"][0]["joints"] = joints
    legs["legs"][0]["name"] = "front_left"
    saved = client.post("/api/robots", files=model, data={"legs": json.dumps(legs)}, headers=A)
    assert saved.status_code == 201 and saved.json()["legs"]["legs"][0]["name"] == "front_left"
    rid = saved.json()["id"]

    assert client.get(f"/api/robots/{rid}/preview-link", headers=B).status_code == 404
    assert client.get(f"/api/robots/{rid}/preview.viser", headers=B).status_code == 404
    assert client.get(f"/api/robots/{rid}/preview.viser").status_code == 401
    url = client.get(f"/api/robots/{rid}/preview-link", headers=A).json()["url"]
    scene = client.get(url)  # no header: the signed link alone
    assert scene.status_code == 200 and len(scene.content) > 1000
    assert (store.robot_dir(settings.data_dir, rid) / "preview.viser").read_bytes() == scene.content
    other = saved.json()["id"][::-1]
    assert client.get(url.replace(rid, other)).status_code in (401, 404)
    assert client.delete(f"/api/robots/{rid}", headers=A).status_code == 204
    assert _stored(settings) == (0, [])

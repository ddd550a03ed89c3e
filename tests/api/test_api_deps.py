"""What the routes share (app/api/deps.py): one database dependency serves the jobs,
studies, service and dashboard routes; a 405 names every method of the path, those of
included routers too; every page carries the colour table of app/core/colors.py."""

from __future__ import annotations

import json
import re

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated

from app.api import create_app
from app.api.deps import Db, get_db
from app.core import colors


@pytest.fixture
def settings(tmp_path):
    return migrated(deployment(tmp_path))


class CountingDb(Db):
    """The real database, counting the transactions each route opens through the dependency."""

    calls = 0

    async def run(self, fn, readonly=False, missing="job"):
        CountingDb.calls += 1
        return await super().run(fn, readonly=readonly, missing=missing)

    def session(self, readonly=False):
        CountingDb.calls += 1
        return super().session(readonly=readonly)


@pytest.mark.parametrize("method,path", [
    ("GET", "/api/jobs"), ("GET", "/api/jobs/nope"), ("GET", "/api/jobs/nope/history"),
    ("POST", "/api/jobs/nope/cancel"), ("GET", "/api/studies"), ("GET", "/api/studies/nope"),
    ("GET", "/api/health"), ("GET", "/api/jobs/nope/views"), ("GET", "/api/jobs/nope/files"),
])
def test_every_route_reaches_the_database_through_one_dependency(settings, method, path):
    app = create_app(settings)
    app.dependency_overrides[get_db] = lambda: CountingDb(settings.db_url)
    CountingDb.calls = 0
    r = TestClient(app).request(method, path)
    assert r.status_code in (200, 404), r.text
    assert CountingDb.calls >= 1
    if r.status_code == 404:
        what = "study" if "studies" in path else "job"
        assert r.json()["detail"] == f"no {what} 'nope'"


def test_a_405_names_every_method_of_the_path(settings):
    client = TestClient(create_app(settings))
    r = client.put("/api/jobs/abc")  # GET and DELETE: two routes of the jobs router
    assert r.status_code == 405 and r.headers["allow"] == "DELETE, GET"
    r = client.post("/api/jobs/abc/views")  # a dashboard route
    assert r.status_code == 405 and r.headers["allow"] == "GET"


def test_pages_carry_the_colour_table(settings):
    html = TestClient(create_app(settings)).get("/").text
    found = re.search(r'<script id="gm-colors" type="application/json">(.*?)</script>', html)
    assert found and json.loads(found.group(1)) == colors.page_table()
    table = colors.page_table()
    assert table["roles"][table["history"]["best"]] == colors.ROLES["method"]

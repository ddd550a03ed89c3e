"""Browser tests: a real `gaitmend serve` (API + embedded worker, SQLite, temporary data
folder) driven by Debian's Chromium through Playwright. The server runs with API tokens on,
so the dashboard's token path, signed replay links and authorised downloads are exercised.

Screenshots go to $GAITMEND_E2E_SHOTS (default: a temporary folder of the run), to be looked at."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import httpx
import pytest
from service_support import Proc, deployment, free_port, migrated, wait_for

sys.path.insert(0, os.path.dirname(__file__))  # tests/e2e/glance.py: the checks every page of ours gets

# A second, different job for the compare page and the route tests: CMA-ES, legs 1 and 6.
SECOND = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
          "search": {"optimizer": "cmaes", "population": 6, "generations": 2, "seed": 4}, "sim": {"duration_s": 1.5}}

CHROMIUM = os.environ.get("GAITMEND_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]
DESKTOP = {"width": 1280, "height": 800}



class Server:
    def __init__(self, url: str, settings, tokens: dict[str, str], proc: Proc):
        self.url, self.settings, self.tokens, self.proc = url, settings, tokens, proc

    def client(self, owner: str = "alice") -> httpx.Client:
        return httpx.Client(base_url=self.url, timeout=30,
                            headers={"Authorization": f"Bearer {self.tokens[owner]}"} if owner else {})


def serve(tmp: Path, env: dict, settings, owners: tuple[str, ...]):
    """Runs `gaitmend serve` (env as given) until the generator is closed; yields the Server
    once /api/health answers, with a token per owner in the migrated database."""
    from app.store import repo
    from app.store.db import session_scope

    with session_scope(settings.db_url) as s:
        tokens = {name: repo.create_token(s, name) for name in owners}
    port = free_port()
    proc = Proc(["serve", "--host", "127.0.0.1", "--port", str(port)], env, tmp / "serve.log")
    url = f"http://127.0.0.1:{port}"

    def up():
        try:
            return httpx.get(f"{url}/api/health", timeout=2).status_code == 200
        except httpx.HTTPError:
            return False

    try:
        wait_for(up, 90, "gaitmend serve to answer /api/health", interval=0.3, proc=proc)
        yield Server(url, settings, tokens, proc)
    finally:
        proc.stop()


@pytest.fixture(scope="session")
def server(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("e2e")
    env = deployment(tmp, auth="on", lease_s=30, redispatch_after_s=120)
    yield from serve(tmp, env, migrated(env), ("alice", "bob", "carol"))


@pytest.fixture(scope="session")
def second_job(server) -> str:
    """alice's SECOND job, submitted through the API and finished (succeeded)."""
    with server.client("alice") as c:
        jid = c.post("/api/jobs", json=SECOND).json()["id"]
        wait_for(lambda: c.get(f"/api/jobs/{jid}").json()["status"] in ("succeeded", "failed", "cancelled"), 120,
                 "the second job to finish", interval=0.3, proc=server.proc)
        job = c.get(f"/api/jobs/{jid}").json()
    assert job["status"] == "succeeded", job["error"]
    return jid


@pytest.fixture(scope="session")
def browser():
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).exists():
        reason = (f"{CHROMIUM} is missing: apt-get install chromium (scripts/test.sh does it as root) "
                  "or set GAITMEND_CHROMIUM")
        if os.environ.get("CI"):  # as tests/conftest.py's unavailable(): CI must have it
            pytest.fail(reason + " (CI is set, so a missing browser fails instead of skipping)")
        pytest.skip(reason)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="session")
def shots(tmp_path_factory) -> Path:
    # never into the checkout (the suite writes nothing there): a temporary folder unless asked
    d = Path(os.environ.get("GAITMEND_E2E_SHOTS") or tmp_path_factory.mktemp("screenshots"))
    d.mkdir(parents=True, exist_ok=True)
    return d


def _context(browser, server, viewport, owner):
    ctx = browser.new_context(viewport=viewport, accept_downloads=True)
    if owner:
        ctx.add_init_script(f"localStorage.setItem('gaitmend.token', {server.tokens[owner]!r})")
    return ctx


@pytest.fixture
def page(browser, server):
    """A desktop page (1280x800) whose dashboard holds alice's token; console errors fail the test."""
    ctx = _context(browser, server, DESKTOP, "alice")
    pg = ctx.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    yield pg
    ctx.close()
    assert not errors, f"JavaScript errors on the page: {errors}"


@pytest.fixture
def new_page(browser, server):
    """Factory for extra pages: new_page(viewport=PHONE, owner='bob')."""
    made = []

    def make(viewport=DESKTOP, owner="alice"):
        ctx = _context(browser, server, viewport, owner)
        made.append(ctx)
        return ctx.new_page()

    yield make
    for c in made:
        c.close()

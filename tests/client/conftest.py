"""One real `gaitmend serve` (embedded broker, SQLite, one worker) for the whole session:
the Python client, the bundle reader, the videos, the generated client and the notebook
all talk to it. Every kind's smoke job is submitted once, at the start, so the worker
runs them while the first tests wait."""

from __future__ import annotations

import httpx
import pytest
from service_support import Proc, deployment, free_port, wait_for


@pytest.fixture(scope="session")
def served(tmp_path_factory):
    """(base URL, the server's Proc, its env) of a served instance."""
    tmp = tmp_path_factory.mktemp("served")
    env = deployment(tmp, worker_concurrency=2)  # two job slots: both cores busy while the kinds' jobs run
    port = free_port()
    proc = Proc(["serve", "--port", str(port)], env, tmp / "serve.log")
    base = f"http://127.0.0.1:{port}"

    def up():
        try:
            return httpx.get(f"{base}/api/health", timeout=2).status_code == 200
        except httpx.HTTPError:
            return proc.p.poll() is not None and pytest.fail(f"serve exited:\n{proc.tail()}")

    try:
        wait_for(up, 90, "the server", proc=proc)
        yield base, proc, env
    finally:
        proc.stop()


@pytest.fixture(scope="session")
def client(served):
    import gaitmend

    with gaitmend.Client(served[0], token="") as c:
        yield c


@pytest.fixture(scope="session")
def kind_jobs(client):
    """{kind: Job} of every registered kind's smoke spec, submitted (not waited for)."""
    from app.jobs.registry import KINDS

    return {name: client.submit(kind.smoke_spec()) for name, kind in KINDS.items() if kind.smoke_spec()}


@pytest.fixture(scope="session")
def finished(kind_jobs, served):
    """The same jobs, finished: each must have succeeded."""
    out = {}
    for name, job in kind_jobs.items():
        job.wait(progress=False, timeout=300)
        assert job.status == "succeeded", (name, job.info.get("error"), served[1].tail())
        out[name] = job
    return out


@pytest.fixture(scope="session")
def bundles(finished, tmp_path_factory):
    """{kind: path of its downloaded bundle zip}."""
    folder = tmp_path_factory.mktemp("bundles")
    return {name: job.bundle(folder / f"{name}.zip") for name, job in finished.items()}


GENERATOR = "openapi-python-client==0.29.1"


@pytest.fixture(scope="session", autouse=True)
def generator_venv():
    """A venv with openapi-python-client from PyPI, outside the checkout, kept between runs
    (keyed by the pinned version; "ready" marks a finished install). The install starts with
    the session, in the background, while the served worker runs the kinds' jobs; the
    generated-client test waits for it (``.path()``)."""
    import os
    import shutil
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    home = Path(tempfile.gettempdir()) / f"gaitmend-{GENERATOR.replace('==', '-')}"
    proc = None
    if not (home / "ready").exists():
        shutil.rmtree(home, ignore_errors=True)  # a half-made one from an interrupted run
        env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
        script = (f"'{sys.executable}' -m venv '{home}' && '{home}/bin/python' -m pip install -q "
                  f"--disable-pip-version-check '{GENERATOR}' && echo {GENERATOR} > '{home}/ready'")
        proc = subprocess.Popen(["bash", "-c", script], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)

    class Pending:
        def path(self, timeout: float = 600) -> Path:
            if proc is not None and proc.wait(timeout) != 0:
                raise AssertionError(f"installing {GENERATOR} failed:\n{proc.stdout.read().decode()[-3000:]}")
            return home

    yield Pending()
    if proc is not None and proc.poll() is None:
        proc.kill()

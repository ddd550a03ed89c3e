"""The commands a user types: `gaitmend serve` (embedded worker, restarted after kill -9),
`submit --wait`, `jobs`, `fetch`, `cancel`, `token`, `db`, and `gaitmend run manifest.json`
reproducing a fetched bundle."""

from __future__ import annotations

import json
import os
import signal
import zipfile

import httpx
import pytest
from service_support import SMALL, Proc, deployment, free_port, job_row, proc_env, settings_of, spec, wait_for


def gaitmend(env, *args):
    """The CLI in this process (a fresh interpreter costs seconds of imports); the server
    it talks to is a real process."""
    from typer.testing import CliRunner

    from app.cli import cli

    r = CliRunner().invoke(cli, list(args), env=env | {"COLUMNS": "240"}, catch_exceptions=False)
    r.returncode = r.exit_code
    return r


@pytest.fixture
def served(tmp_path):
    procs = []

    def start(env, *extra):
        port = free_port()
        p = Proc(["serve", "--port", str(port), *extra], env, tmp_path / f"serve{len(procs)}.log")
        procs.append(p)
        base = f"http://127.0.0.1:{port}"

        def up():
            try:
                return httpx.get(f"{base}/api/health", timeout=2).status_code == 200
            except httpx.HTTPError:
                return p.p.poll() is not None and pytest.fail(f"serve exited:\n{p.tail()}")

        wait_for(up, 60, "the server", proc=p)
        return base, p

    yield start
    for p in procs:
        p.stop()


def test_serve_submit_wait_fetch_and_reproduce(tmp_path, served):
    env = deployment(tmp_path)
    base, server = served(env)
    env_c = env | {"GAITMEND_SERVER": base}
    (tmp_path / "spec.json").write_text(json.dumps(SMALL))
    r = gaitmend(env_c, "submit", str(tmp_path / "spec.json"), "--wait", "--json")
    assert r.returncode == 0, r.stderr
    job = json.loads(r.stdout)
    assert job["status"] == "succeeded" and job["progress"]["done"] == job["progress"]["total"] > 0
    listed = json.loads(gaitmend(env_c, "jobs", "--json").stdout)
    assert [j["id"] for j in listed["items"]] == [job["id"]]
    r = gaitmend(env_c, "fetch", job["id"], "--out", str(tmp_path / "got"), "--json")
    assert r.returncode == 0, r.stderr
    bundle = json.loads(r.stdout)["bundle"]
    with zipfile.ZipFile(bundle) as z:
        z.extractall(tmp_path / "unzipped")
    r = gaitmend(env_c, "run", str(tmp_path / "unzipped" / "manifest.json"), "--json", "--quiet",
                 "--out", str(tmp_path / "again"))
    assert r.returncode == 0, r.stderr
    again = json.loads(r.stdout.strip().splitlines()[-1])
    assert again["best"] == job["summary"]["best"] and again["history"] == job["summary"]["history"]
    # client-side errors: bad spec (exit 2, field named, nothing sent), unknown job
    (tmp_path / "bad.json").write_text(json.dumps(SMALL | {"search": {"population": 1}}))
    r = gaitmend(env_c, "submit", str(tmp_path / "bad.json"))
    assert r.returncode == 2 and "search.population" in r.stderr
    r = gaitmend(env_c, "fetch", "nope")
    assert r.returncode == 2 and "no job" in r.stderr
    assert len(json.loads(gaitmend(env_c, "jobs", "--json").stdout)["items"]) == 1


def test_serve_restarts_its_embedded_worker_after_kill9_and_the_job_resumes(tmp_path, served):
    env = deployment(tmp_path)
    settings = settings_of(env)
    base, server = served(env)
    jid = httpx.post(f"{base}/api/jobs", json=spec(generations=14, population=8, seed=3)).json()["id"]
    wait_for(lambda: job_row(settings, jid).progress_done >= 3, 90, "three generations", proc=server)
    child = int(job_row(settings, jid).worker.rsplit(":", 1)[1])
    os.killpg(os.getpgid(child), signal.SIGKILL)  # the embedded worker, main process and pool
    job = wait_for(lambda: (j := job_row(settings, jid)).status in ("succeeded", "failed") and j, 120,
                   "the job to finish", proc=server)
    assert (job.status, job.attempt) == ("succeeded", 2), job.error
    assert "restarting it" in server.log.read_text()
    r = gaitmend(env | {"GAITMEND_SERVER": base}, "cancel", jid)
    assert r.returncode == 0 and "succeeded" in r.stdout  # cancelling a finished job changes nothing


def test_public_bind_needs_a_token(tmp_path, served):
    env = deployment(tmp_path)
    r = gaitmend(env, "token", "create", "alice")  # no database here yet: refused, saying where it looked
    assert r.returncode == 2 and "no gaitmend database at sqlite:///" in r.stderr and "--init" in r.stderr
    assert not (tmp_path / "data" / "gaitmend.db").exists()
    for args in (["list"], ["list", "--json"], ["revoke", "alice"]):  # nor do list and revoke create one
        r = gaitmend(env, "token", *args)
        assert r.returncode == 2 and "no gaitmend database at sqlite:///" in r.stderr, (args, r.stderr)
        assert "Traceback" not in r.stderr + r.stdout and not r.stdout
    assert not (tmp_path / "data" / "gaitmend.db").exists()
    r = gaitmend(env, "token", "create", "alice", "--init")
    assert r.returncode == 0, r.stderr
    assert f"stored in sqlite:///{(tmp_path / 'data' / 'gaitmend.db').resolve()}" in " ".join(r.stderr.split())
    token = r.stdout.strip()
    assert token.startswith("gm_")
    assert gaitmend(env, "token", "create", "alice").returncode == 2  # names are unique
    assert gaitmend(env, "token", "create", "bad name!").returncode == 2
    base, _ = served(env | {"GAITMEND_AUTH": "on"}, "--no-worker")  # same code path as a 0.0.0.0 bind
    assert httpx.get(f"{base}/api/jobs").status_code == 401
    r = httpx.get(f"{base}/api/jobs", headers={"Authorization": f"Bearer {token}"})
    assert r.status_code == 200
    (tmp_path / "spec.json").write_text(json.dumps(SMALL))
    env_c = env | {"GAITMEND_SERVER": base}
    assert gaitmend(env_c, "submit", str(tmp_path / "spec.json")).returncode == 1  # 401: not a usage error
    r = gaitmend(env_c | {"GAITMEND_TOKEN": token}, "submit", str(tmp_path / "spec.json"), "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["owner"] == "alice"
    r = gaitmend(env, "token", "list", "--json")
    listed = json.loads(r.stdout)
    assert [t["name"] for t in listed] == ["alice"] and token not in json.dumps(listed)
    db = f"sqlite:///{(tmp_path / 'data' / 'gaitmend.db').resolve()}"
    assert f"1 token in {db}" in " ".join(r.stderr.split())  # says which database it read
    r = gaitmend(env, "token", "revoke", "alice")
    assert r.returncode == 0 and f"revoked alice in {db}" in " ".join(r.stdout.split())
    assert httpx.get(f"{base}/api/jobs", headers={"Authorization": f"Bearer {token}"}).status_code == 401
    r = gaitmend(env, "token", "revoke", "alice")
    assert r.returncode == 1 and f"no token named 'alice' in {db}" in " ".join(r.stderr.split())


def test_an_error_is_one_line_in_a_pipe_whatever_its_length(tmp_path):
    """A message to a pipe or a log is never broken inside a path: rich wrapped stderr at 80
    columns, so a long data folder split "sqlite:///..." over two lines (seen under pytest-xdist,
    whose temporary folders are longer)."""
    deep = tmp_path / ("a-long-folder-name-" * 12)
    deep.mkdir()
    env = deployment(deep)
    r = gaitmend(env, "token", "list")
    where = f"sqlite:///{(deep / 'data' / 'gaitmend.db').resolve()}"
    assert len(where) > 240 and r.returncode == 2, r.stderr  # beyond the COLUMNS=240 the tests set
    line = next(ln for ln in r.stderr.splitlines() if "no gaitmend database" in ln)
    assert where in line, r.stderr


def test_bad_settings_and_db_commands(tmp_path):
    env = deployment(tmp_path)
    r = gaitmend(env | {"GAITMEND_LEASE_S": "0"}, "db", "upgrade")
    assert r.returncode == 2 and "GAITMEND_LEASE_S" in r.stderr and "greater than or equal to 1" in r.stderr
    r = gaitmend(env | {"GAITMEND_BROKER_URL": "amqp://x"}, "worker")
    assert r.returncode == 2 and "GAITMEND_BROKER_URL" in r.stderr
    r = gaitmend(env | {"GAITMEND_MAX_JOB_S": "50000"}, "db", "upgrade")
    assert r.returncode == 2 and "GAITMEND_VISIBILITY_TIMEOUT_S" in r.stderr
    r = gaitmend(env, "worker")  # no schema yet: a clear message, not a traceback
    assert r.returncode == 1 and "gaitmend db upgrade" in r.stderr
    from app.store.migrate import head

    latest = head("sqlite://")  # the newest migration (the script folder, whatever the database)
    r = gaitmend(env, "db", "upgrade")
    assert r.returncode == 0 and r.stdout.strip() == latest
    assert f"{latest} (head: {latest})" in gaitmend(env, "db", "current").stdout


def test_jobs_table_prefixes_readable_job_retry_delete(tmp_path, served):
    import subprocess
    import sys

    env = deployment(tmp_path)
    base, server = served(env)
    env_c = env | {"GAITMEND_SERVER": base}
    jid = httpx.post(f"{base}/api/jobs", json=SMALL).json()["id"]
    wait_for(lambda: httpx.get(f"{base}/api/jobs/{jid}").json()["status"] == "succeeded", 120, "the job", proc=server)
    # a pipe at 80 columns: nothing cut, damage and the headline value shown
    p = subprocess.run([sys.executable, "-m", "app", "jobs"], capture_output=True, text=True, timeout=120,
                       env=proc_env(env_c) | {"COLUMNS": "80"})
    assert p.returncode == 0, p.stderr
    assert "\u2026" not in p.stdout and "..." not in p.stdout, p.stdout
    row = next(line for line in p.stdout.splitlines() if jid[:8] in line)
    headline = httpx.get(f"{base}/api/jobs/{jid}").json()["headline"][0]["label"]
    assert "lost 1,6" in row and "succeeded" in row and headline in row, p.stdout
    r = gaitmend(env_c, "jobs", jid[:8])  # the prefix the table shows is accepted everywhere
    assert r.returncode == 0 and f"job {jid}" in r.stdout and len(r.stdout.splitlines()) < 80, r.stdout
    assert "before" in r.stdout.lower() or "F" in r.stdout  # the kind's summary table, not raw JSON
    assert not r.stdout.lstrip().startswith("{")
    r = gaitmend(env_c, "retry", jid[:8])
    assert r.returncode == 2 and "status" in r.stderr and "succeeded" in r.stderr
    r = gaitmend(env_c, "delete", jid[:7])
    assert r.returncode == 0 and f"{jid} deleted" in r.stdout
    assert httpx.get(f"{base}/api/jobs/{jid}").status_code == 404


def test_submit_wait_prints_the_id_at_once_and_the_reason_at_the_end(tmp_path, served):
    import subprocess
    import sys

    env = deployment(tmp_path)
    base, server = served(env)
    (tmp_path / "long.json").write_text(json.dumps(spec(generations=200, population=8, seed=5)))
    p = subprocess.Popen([sys.executable, "-m", "app", "submit", str(tmp_path / "long.json"), "--wait"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=proc_env(env | {"GAITMEND_SERVER": base}))
    try:
        jid = p.stdout.readline().strip()  # before the job ends: a script can act on it
        assert len(jid) == 32, jid
        wait_for(lambda: httpx.get(f"{base}/api/jobs/{jid}").json()["status"] == "running", 60, "running",
                 proc=server)
        assert p.poll() is None
        assert httpx.post(f"{base}/api/jobs/{jid}/cancel").status_code == 202
        out, errtext = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 1
    assert "cancelled: cancelled on request" in errtext.splitlines()[-1], errtext


def test_serve_on_a_busy_port_worker_with_a_wrong_broker_and_db_backup(tmp_path):
    import socket
    import time

    env = deployment(tmp_path)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = gaitmend(env, "serve", "--port", str(port))
    assert r.returncode == 1 and "cannot listen on 127.0.0.1" in r.stderr and "http://" not in r.stdout + r.stderr
    assert gaitmend(env, "db", "upgrade").returncode == 0
    t = time.monotonic()
    r = gaitmend(env | {"GAITMEND_BROKER_URL": "redis://127.0.0.1:1/0"}, "worker")
    assert r.returncode == 1 and "cannot reach the broker redis://127.0.0.1:1/0" in r.stderr, r.stderr
    assert time.monotonic() - t < 15
    r = gaitmend(env, "db", "backup", str(tmp_path / "copy.db"))
    assert r.returncode == 0 and "0 jobs" in r.stdout, r.stderr
    r = gaitmend(env, "db", "backup", str(tmp_path / "copy.db"))
    assert r.returncode == 2 and "--force" in r.stderr

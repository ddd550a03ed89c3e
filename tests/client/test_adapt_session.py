"""An adaptation session survives a restart (issue 44): a real `gaitmend serve` (API and
embedded worker, SQLite) builds a small repertoire, the Python client starts a session and
posts two trials, the server's whole process group is killed with SIGKILL and started
again on the same data folder, and the session goes on: its stored trials are unchanged
and its proposals are those of a session that was never interrupted."""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile

import httpx
import pytest
from service_support import ENTRY, Proc, deployment, free_port, proc_env, wait_for

import gaitmend

SPEC = {"kind": "repertoire", "seed": 5, "archive": {"cells": 30},
        "search": {"iterations": 4, "batch_size": 8, "checkpoint_every": 4},
        "sim": {"duration_s": 1.0, "settle_s": 0.1, "timestep_s": 0.004},
        "evidence": {"rescore_elites": 0, "random_control": False}}
TRIALS = 5


def _measured(k: int) -> dict:
    """Backwards, slower than any prediction: the session runs all its trials (no early stop)."""
    return {"forward_m": -0.001 * k, "lateral_m": 0.004 * (-1) ** k, "yaw_deg": 2.0 * k, "fell": k == 2,
            "duration_s": 1.0}


def _start(env, log):
    port = free_port()
    proc = Proc(["serve", "--port", str(port)], env, log)
    base = f"http://127.0.0.1:{port}"

    def up():
        try:
            return httpx.get(f"{base}/api/health", timeout=2).status_code == 200
        except httpx.HTTPError:
            return proc.p.poll() is not None and pytest.fail(f"serve exited:\n{proc.tail()}")

    wait_for(up, 120, "the server", proc=proc)
    return base, proc


def _post(c, sid, k):
    s = c.post_trial(sid, k, **_measured(k), note=f"trial {k}")
    return s["next"], s


def test_a_session_survives_a_kill_9_of_serve_and_its_worker(tmp_path):
    env = deployment(tmp_path)
    base, proc = _start(env, tmp_path / "serve0.log")
    try:
        with gaitmend.Client(base, token="") as c:
            job = c.submit(SPEC).wait(progress=False, timeout=300)
            assert job.status == "succeeded", (job.info.get("error"), proc.tail())
            s = c.create_adaptation([job.id], method="gaitmend", max_trials=TRIALS, alpha=1.0)
            sid, proposals = s["id"], [s["next"]]
            for k in (1, 2):
                nxt, s = _post(c, sid, k)
                proposals.append(nxt)
            before = c.adaptation_trials(sid)
    finally:
        proc.kill9()  # the process group: serve and its embedded worker, no clean shutdown
        proc.stop()
    base, proc = _start(env, tmp_path / "serve1.log")
    try:
        with gaitmend.Client(base, token="") as c:
            s = c.adaptation(sid)
            assert s["trials"] == before and s["status"] == "open" and s["next"] == proposals[-1]
            with pytest.raises(gaitmend.Conflict) as e:  # the trial posted before the kill stays posted once
                c.post_trial(sid, 2, **_measured(2))
            assert e.value.field == "trial"
            for k in range(3, TRIALS + 1):
                nxt, s = _post(c, sid, k)
                proposals.append(nxt)
            # the same trials, uninterrupted, in a second session over the same map
            u = c.create_adaptation([job.id], method="gaitmend", max_trials=TRIALS, alpha=1.0)
            straight = [u["next"]]
            for k in range(1, TRIALS + 1):
                nxt, last = _post(c, u["id"], k)
                straight.append(nxt)
            assert proposals == straight and proposals[-1] is None
            strip = lambda ts: [{k: v for k, v in t.items() if k != "created_at"} for t in ts]  # noqa: E731
            assert strip(s["trials"]) == strip(last["trials"]) and len(s["trials"]) == TRIALS
            assert s["decision"] == last["decision"] and s["status"] == last["status"] == "finished"
            zipped = c.proposal_bundle(sid, 3, tmp_path / "trial3.zip")
            with zipfile.ZipFile(zipped) as z:
                assert json.loads(z.read("gait.json")) == proposals[2]
            _the_cli_runs_a_server_session(c, env, job.id, straight, tmp_path)
    finally:
        proc.stop()


def _cli(env, *args, stdin: str = ""):
    return subprocess.run([sys.executable, "-c", ENTRY, "adapt", *args], env=proc_env(env), input=stdin,
                          capture_output=True, text=True, timeout=120)


def _line(k: int) -> str:
    m = _measured(k)
    return f"{m['forward_m']} {m['lateral_m']} {m['yaw_deg']} {'yes' if m['fell'] else 'no'} {m['duration_s']}\n"


def _the_cli_runs_a_server_session(c, env, job_id, straight, tmp_path):
    """`gaitmend adapt --server`: the lab types two trials, stops, goes on with --session
    (a bad line from a pipe is exit 2 and posts nothing) and finishes; the server holds what
    was typed and the CLI proposed what the API proposes."""
    bundles = tmp_path / "for-the-robot"
    r = _cli(env, job_id, "--server", c.server, "--method", "gaitmend", "--max-trials", "3", "--alpha", "1.0",
             "--bundles", str(bundles), stdin=_line(1) + _line(2))
    assert r.returncode == 1, r.stderr  # the input ended before the method stopped
    sid = r.stdout.split("session ", 1)[1].split()[0]
    s = c.adaptation(sid)
    assert [(t["trial"], t["forward_m"], t["fell"]) for t in s["trials"]] == [(1, -0.001, False), (2, -0.002, True)]
    assert [(t["map"], t["elite"]) for t in s["trials"]] == [(p["map"], p["elite"]) for p in straight[:2]]
    with zipfile.ZipFile(bundles / "trial2.zip") as z:
        assert json.loads(z.read("gait.json"))["elite"] == straight[1]["elite"]
    assert f"/adaptations/{sid}" in r.stdout and "measurements ended after 2 trials" in r.stdout

    bad = _cli(env, "--session", sid, "--server", c.server, stdin="0.1 0 0 maybe 10\n")
    assert bad.returncode == 2 and "fell" in bad.stderr, bad.stderr
    assert c.adaptation(sid)["trials_done"] == 2  # nothing written
    mixed = _cli(env, job_id, "--session", sid, "--server", c.server)
    assert mixed.returncode == 2 and "--session" in mixed.stderr
    refused = _cli(env, job_id, "--server", c.server, "--alpha", "7", stdin="")
    assert refused.returncode == 2 and "alpha" in refused.stderr, refused.stderr

    done = _cli(env, "--session", sid, "--server", c.server, "--json", stdin=_line(3))
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["session"] == sid and out["status"] == "finished" and len(out["trials"]) == 3
    assert out["trials"] == c.adaptation_trials(sid)

"""Issue 27, fifth fault: the data folder's disk full, on a tiny tmpfs mounted for the test
(root only), for both stores: the embedded default (`gaitmend serve`: SQLite, the broker
and the bundles all on that disk) and PostgreSQL with Redis (the bundles on it). Five
times each, the disk is filled while a job runs: the job must wait (not fail) and finish
with the undisturbed numbers once space returns, /api/health must say the disk is low,
DELETE must free space on the full disk, and every other answer must be a success or a
JSON 503 with Retry-After naming the data folder."""

from __future__ import annotations

import contextlib
import os
import subprocess

import pytest
from fault_support import Watcher, ballistic, can_mount_tmpfs, check_answers
from service_support import wait_for

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not can_mount_tmpfs(), reason="mounting a tmpfs needs root")]

SPEC = ballistic(generations=8, population=16, duration_s=2.0)
ROUNDS = 5
SIZE_MB = 40


@pytest.fixture
def disk(tmp_path):
    mnt = tmp_path / "disk"
    mnt.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={SIZE_MB}m", "tmpfs", str(mnt)], check=True)
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)


def fill(path) -> None:
    """Write until the disk is full."""
    f = open(path, "wb", buffering=0)
    try:
        while True:
            f.write(b"\0" * 65536)
    except OSError:
        pass
    finally:
        with contextlib.suppress(OSError):
            f.close()


def log_of(st) -> str:
    return "".join(p.log.read_text(errors="replace") for p in [st.serve, *st.workers])


def run_rounds(st, disk):
    data = st.settings.data_dir
    specs, answers, deleted = {}, [], []
    with Watcher(st.base, ["/api/jobs?limit=5"]) as watch:
        previous = None
        for r in range(ROUNDS):
            jid = st.submit(SPEC)
            specs[jid] = SPEC
            wait_for(lambda: (j := st.row(jid)).status == "running" and j.progress_done >= 2, 60, "the job running",
                     proc=st.serve)
            filler = disk / f"filler{r}"
            fill(filler)
            # the job waits for space (a checkpoint, progress or its bundle), it does not fail
            wait_for(lambda: "no space left" in log_of(st).split(f"job {jid} attempt 1 claimed", 1)[-1], 60,
                     "the job to wait for space", proc=st.serve)
            h = wait_for(lambda: (h := st.client.get("/api/health").json())["status"] == "degraded" and h, 30,
                         "health to report the full disk")
            assert any(x.startswith("disk: ") and str(data.resolve()) in x for x in h["reasons"]), h
            assert h["disk"]["low"] is True and h["disk"]["free_bytes"] < 1024 * 1024, h["disk"]
            r_post = st.client.post("/api/jobs", json=SPEC)
            answers.append(("/api/jobs", r_post.status_code, dict(r_post.headers), r_post.text))
            if r_post.status_code == 201:  # PostgreSQL: the row is elsewhere; it runs later
                specs[r_post.json()["id"]] = SPEC
            else:
                assert str(data.resolve()) in r_post.json()["detail"], r_post.text
            if previous:  # deleting a job is the way to free space: it must work on a full disk
                r_del = st.client.delete(f"/api/jobs/{previous}")
                assert r_del.status_code == 204, r_del.text
                specs.pop(previous)
                deleted.append(previous)
            assert st.row(jid).status == "running"
            filler.unlink()
            assert st.wait_final([jid], 120)[jid].status == "succeeded", st.row(jid).error
            previous = jid
    answers += watch.answers
    return specs, answers, deleted


def test_a_full_disk_embedded_sqlite(tmp_path, disk, stacks):
    st = stacks(tmp_path, workers=0, serve_worker=True, data_dir=disk / "data", space_reserve_mb=1, min_free_mb=4,
                storage_wait_s=120)
    specs, answers, deleted = run_rounds(st, disk)
    st.wait_final(list(specs), 120)
    st.check_results(specs)
    assert len(deleted) == ROUNDS - 1 and all(st.client.get(f"/api/jobs/{j}").status_code == 404 for j in deleted)
    assert not any((st.settings.bundle_dir / f"{j}.zip").exists() for j in deleted)
    assert check_answers(answers) >= 1  # SQLite on the full disk: POST answered a JSON 503
    wal = st.settings.data_dir / "gaitmend.db-wal"
    print(f"sqlite WAL {wal.stat().st_size if wal.exists() else 0} bytes; "
          f"data folder {sum(p.stat().st_size for p in st.settings.data_dir.rglob('*') if p.is_file())} bytes")


def test_a_full_disk_postgresql(tmp_path, disk, pg_url, redis_url, stacks):
    st = stacks(tmp_path, workers=1, database_url=pg_url, broker=redis_url, data_dir=disk / "data", space_reserve_mb=1,
                min_free_mb=4, storage_wait_s=120)
    st.wait_ready(st.workers[0])
    specs, answers, deleted = run_rounds(st, disk)
    st.wait_final(list(specs), 180)
    st.check_results(specs)
    assert len(deleted) == ROUNDS - 1 and all(st.client.get(f"/api/jobs/{j}").status_code == 404 for j in deleted)
    check_answers(answers)

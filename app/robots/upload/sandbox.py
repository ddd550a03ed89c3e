"""Compile an uploaded model in a separate, confined process (child.py): an empty working
folder, a minimal environment, address-space, CPU-time and file-size limits, no file
access at all once it has read its input (Landlock, where the kernel has it), and a
wall-clock limit enforced from here."""

from __future__ import annotations

import base64
import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

from app.robots.upload.errors import RefusedUpload
from app.robots.upload.limits import LIMITS, Limits
from app.robots.upload.mjcf import Sanitised

_ROOT = Path(__file__).resolve().parents[3]  # the folder holding the app package
# At most this many confined compiles at once per process (each may map +1 GiB): more
# uploads wait their turn instead of exhausting the machine's memory together.
MAX_CONCURRENT = 2
_slots = threading.BoundedSemaphore(MAX_CONCURRENT)


def _env() -> dict[str, str]:
    keep = ("PATH", "LANG", "LC_ALL", "OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")
    env = {k: os.environ[k] for k in keep if k in os.environ}
    env.update(PYTHONPATH=str(_ROOT), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               PYTHONDONTWRITEBYTECODE="1", MUJOCO_GL="disable")
    return env


def compile_confined(model: Sanitised, legs: dict | None, forward: str | None, limits: Limits = LIMITS) -> dict:
    """The child's answer (ok, legs, detected, points, stats, sandbox) or RefusedUpload."""
    with _slots:
        return _compile(model, legs, forward, limits)


def _compile(model: Sanitised, legs: dict | None, forward: str | None, limits: Limits) -> dict:
    payload = json.dumps({"xml": model.xml, "assets": {k: base64.b64encode(v).decode() for k, v in model.assets.items()},
                          "legs": legs, "forward": forward, "limits": dataclasses.asdict(limits)}).encode()
    read_fd, write_fd = os.pipe()
    try:
        with tempfile.TemporaryDirectory(prefix="gaitmend-compile-") as empty:
            proc = subprocess.Popen([sys.executable, "-s", "-m", "app.robots.upload.child", str(write_fd)],
                                    stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    cwd=empty, env=_env(), pass_fds=(write_fd,), start_new_session=True)
            os.close(write_fd)
            write_fd = -1
            try:
                _, err = proc.communicate(payload, timeout=limits.compile_wall_s)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.communicate()
                raise RefusedUpload(f"compiling the model took longer than {limits.compile_wall_s:g} s") from None
            with os.fdopen(read_fd, "rb") as f:
                read_fd = -1
                raw = f.read(16 * 1024 * 1024)
    finally:
        for fd in (read_fd, write_fd):
            if fd >= 0:
                os.close(fd)
    return _answer(proc.returncode, raw, err, limits)


def _answer(code: int, raw: bytes, err: bytes, limits: Limits) -> dict:
    if raw.strip():
        answer = json.loads(raw.decode().strip().splitlines()[-1])
        if not answer.get("ok"):
            raise RefusedUpload(answer["error"], field=answer.get("field", "model"))
        return answer
    if code == -signal.SIGXCPU or code == -signal.SIGKILL and b"CPU" in err:
        raise RefusedUpload(f"compiling the model used more than {limits.compile_cpu_s} s of CPU time")
    if b"MemoryError" in err or b"bad_alloc" in err or code in (-signal.SIGSEGV, -signal.SIGABRT, -signal.SIGKILL):
        raise RefusedUpload(f"compiling the model ran out of its memory limit "
                            f"({limits.compile_memory_bytes // (1024 * 1024)} MiB) or crashed")
    raise RefusedUpload(f"the model could not be compiled (the compiling process ended with status {code})")

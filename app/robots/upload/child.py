"""The compile of an uploaded model, run as its own process (app/robots/upload/sandbox.py
starts it in an empty folder): reads the sanitised model from stdin, then, before touching
it, limits its own address space, CPU time and file sizes and (where the kernel has
Landlock) gives up every file-system access; compiles, checks the compiled sizes, finds or
checks the legs, and writes one JSON line to the descriptor it was given."""

from __future__ import annotations

import base64
import ctypes
import json
import os
import resource
import sys

# Landlock (Linux >= 5.13): a ruleset that handles every file-system right and grants none.
_SYS_CREATE, _SYS_RESTRICT = 444, 446
_PR_SET_NO_NEW_PRIVS = 38
_FS_RIGHTS = {1: (1 << 13) - 1, 2: (1 << 14) - 1, 3: (1 << 15) - 1, 4: (1 << 15) - 1, 5: (1 << 16) - 1}


def _landlock() -> bool:
    """Forbid this process every file open from here on; False where the kernel cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        abi = libc.syscall(_SYS_CREATE, None, ctypes.c_size_t(0), ctypes.c_uint32(1))
        if abi < 1:
            return False
        attr = ctypes.c_uint64(_FS_RIGHTS[min(abi, 5)])
        fd = libc.syscall(_SYS_CREATE, ctypes.byref(attr), ctypes.c_size_t(8), ctypes.c_uint32(0))
        if fd < 0:
            return False
        if libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
            return False
        ok = libc.syscall(_SYS_RESTRICT, fd, ctypes.c_uint32(0)) == 0
        os.close(fd)
        return ok
    except (OSError, AttributeError):
        return False


def _vm_size() -> int:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _confine(limits: dict) -> dict:
    base = _vm_size()
    resource.setrlimit(resource.RLIMIT_AS, (base + limits["compile_memory_bytes"],) * 2)
    cpu = int(limits["compile_cpu_s"])
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return {"landlock": _landlock(), "address_space_bytes": base + limits["compile_memory_bytes"], "cpu_s": cpu}


def main() -> int:
    out = os.fdopen(int(sys.argv[1]), "w")
    request = json.loads(sys.stdin.buffer.read())
    assets = {k: base64.b64decode(v) for k, v in request["assets"].items()}
    import mujoco  # noqa: F401  (every import before the confinement: no file opens after it)
    import numpy  # noqa: F401

    from app.robots.upload import compiled

    sandbox = _confine(request["limits"])
    try:
        answer = compiled.examine(request["xml"], assets, request["legs"], request["forward"], request["limits"])
    except MemoryError:
        answer = {"ok": False, "error": "compiling the model ran out of its memory limit"}
    answer["sandbox"] = sandbox
    out.write(json.dumps(answer) + "\n")
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

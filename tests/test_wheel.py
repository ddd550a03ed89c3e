"""The wheel carries everything `gaitmend serve` needs (issue 16.3): build it from a copy
of the source (nothing is written into the checkout), install it - really install the
built wheel, with pip - into a fresh venv, then serve, submit, wait and fetch.

Fast: `--no-deps`, and the fresh venv sees the test environment's site-packages through
a .pth line for the dependencies only (a path line does not run the editable install's
hooks there, so `import app` can only find the wheel's copy, which the test checks)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import time
import zipfile
from pathlib import Path

import httpx
from service_support import free_port, wait_for

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("pyproject.toml", "setup.py", "README.md", "LICENSE", "app", "workers", "gaitmend", "web", "migrations")
SPEC = {"kind": "recovery", "damage": {"lost_legs": [1, 6]},
        "search": {"population": 4, "generations": 1, "seed": 3}, "sim": {"duration_s": 1.0}}


def _clean_env(**extra) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("GAITMEND_", "PYTHON", "VIRTUAL_ENV", "PIP_"))}
    return env | {"PYTHONUNBUFFERED": "1", "PYTHONDONTWRITEBYTECODE": "1"} | extra


def test_wheel_installs_and_serves_in_a_fresh_venv(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        p = ROOT / name
        if p.is_dir():
            shutil.copytree(p, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        elif p.exists():
            shutil.copy2(p, src / name)
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", str(src), "-w", str(dist)],
                   check=True, env=_clean_env(), cwd=tmp_path, timeout=300)
    wheel = next(dist.glob("gaitmend-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "app/_assets/migrations/env.py" in names and "app/_assets/web/templates/index.html" in names
    assert "gaitmend/__init__.py" in names  # `import gaitmend`: the Python client (app/client)
    studies = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "app" / "jobs").glob("*/studies/*.json"))
    assert studies and set(studies) <= set(names), sorted(set(studies) - set(names))  # each kind's built-in studies

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    site = Path(subprocess.check_output([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                        text=True).strip())
    (site / "_gaitmend_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "-q", str(wheel)],
                   check=True, env=_clean_env(), timeout=300)
    where = subprocess.check_output([py, "-c", "import app; print(app.__file__)"], text=True, env=_clean_env(),
                                    cwd=tmp_path).strip()
    assert where.startswith(str(site)), where
    where = subprocess.check_output([py, "-c", "import gaitmend; print(gaitmend.__file__, gaitmend.Client.__module__)"],
                                    text=True, env=_clean_env(), cwd=tmp_path).split()
    assert where[0].startswith(str(site)) and where[1] == "app.client.http", where

    port = free_port()
    log = open(tmp_path / "serve.log", "wb")
    proc = subprocess.Popen([venv / "bin" / "gaitmend", "serve", "--port", str(port)], cwd=tmp_path, stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True,
                            env=_clean_env(GAITMEND_DATA_DIR=str(tmp_path / "data"), PATH=f"{venv / 'bin'}:"
                                           f"{os.environ.get('PATH', '')}"))
    url = f"http://127.0.0.1:{port}"
    try:
        def up():
            try:
                return httpx.get(f"{url}/api/health", timeout=2).status_code == 200
            except httpx.HTTPError:
                return proc.poll() is not None and "exited"

        assert wait_for(up, 90, "the installed gaitmend serve") is True, (tmp_path / "serve.log").read_text()[-3000:]
        assert "gaitmend" in httpx.get(f"{url}/", timeout=10).text  # dashboard templates from the wheel
        assert httpx.get(f"{url}/docs", timeout=10).status_code == 200
        listed = httpx.get(f"{url}/api/studies/builtin", timeout=10).json()["items"]  # read from the wheel's kinds
        assert sorted(i["name"] for i in listed) == sorted(Path(f).stem for f in studies), listed
        job = httpx.post(f"{url}/api/jobs", json=SPEC, timeout=30).json()
        t0 = time.monotonic()
        done = wait_for(lambda: (j := httpx.get(f"{url}/api/jobs/{job['id']}", timeout=10).json())["status"]
                        in ("succeeded", "failed", "cancelled") and j, 180, "the job to finish")
        assert done["status"] == "succeeded", (done["error"], (tmp_path / "serve.log").read_text()[-3000:])
        r = httpx.get(f"{url}/api/jobs/{job['id']}/bundle", timeout=30)
        assert r.status_code == 200 and "manifest.json" in zipfile.ZipFile(__import__("io").BytesIO(r.content)).namelist()
        print(f"\nwheel: built, installed, served; job finished {time.monotonic() - t0:.1f} s after submit")
    finally:
        os.killpg(proc.pid, 15)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, 9)
        log.close()

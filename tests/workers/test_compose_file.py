"""docker-compose.yml (no Docker daemon in CI): services, shared volume, fail-fast secrets,
and that the worker runs the same image and settings as the API."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def test_compose_file_describes_the_distributed_mode():
    doc = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    sv = doc["services"]
    assert {"redis", "db", "api", "worker"} <= set(sv)
    assert sv["worker"]["command"] == ["gaitmend", "worker"]
    assert sv["api"]["command"][:2] == ["gaitmend", "serve"]
    assert sv["worker"]["image"] == sv["api"]["image"]
    assert "replicas" not in str(sv["worker"])  # scaled with --scale worker=N
    for name in ("api", "worker"):
        env = sv[name]["environment"]
        assert env["GAITMEND_BROKER_URL"].startswith("redis://")
        assert env["GAITMEND_DATABASE_URL"].startswith("postgresql://")
        assert ":?" in env["GAITMEND_DATABASE_URL"] and ":?" in env["GAITMEND_BROKER_URL"]  # no default secret
        assert "data:/data" in sv[name]["volumes"]
    assert "data" in doc["volumes"]
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "COPY migrations migrations" in dockerfile and "pip install -e ." in dockerfile

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
    assert sv["worker"]["image"] == sv["api"]["image"] and sv["worker"]["build"] == sv["api"]["build"]
    assert "replicas" not in str(sv["worker"])  # scaled with --scale worker=N
    for name in ("api", "worker"):
        env = sv[name]["environment"]
        assert env["GAITMEND_BROKER_URL"].startswith("redis://")
        assert env["GAITMEND_DATABASE_URL"].startswith("postgresql://")
        # no default secret, and none pasted into a URL (a password with '@' or '/' would break it)
        assert ":?" in env["GAITMEND_DATABASE_PASSWORD"] and ":?" in env["GAITMEND_BROKER_PASSWORD"]
        assert "PASSWORD" not in env["GAITMEND_DATABASE_URL"] + env["GAITMEND_BROKER_URL"]
        assert "data:/data" in sv[name]["volumes"]
    assert "data" in doc["volumes"]
    # a stopped worker hands its job back within GAITMEND_STOP_GRACE_S and exits: the grace
    # period covers that with room to spare, and a worker that exits comes back
    from app.core.settings import Settings

    grace = sv["worker"]["stop_grace_period"]
    assert grace.endswith("s") and Settings.model_fields["stop_grace_s"].default + 5 <= int(grace[:-1]) <= 60, grace
    assert sv["worker"]["restart"] == sv["api"]["restart"] == "unless-stopped"
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "COPY migrations migrations" in dockerfile and "pip install -e ." in dockerfile


def test_passwords_with_at_and_slash_reach_the_servers_intact():
    from sqlalchemy.engine import make_url

    from app.core.settings import load_settings
    from app.service.broker import broker_options

    pw = "p@ss/w:rd%?#"
    s = load_settings(database_url="postgresql://gaitmend@db:5432/gaitmend", database_password=pw,
                      broker_url="redis://redis:6379/0", broker_password=pw)
    url = make_url(s.db_url)
    assert (url.username, url.password, url.host, url.database) == ("gaitmend", pw, "db", "gaitmend")
    from kombu import Connection

    conn = Connection(broker_options(s)[0])
    assert (conn.password, conn.hostname, conn.port) == (pw, "redis", 6379)
    assert pw not in repr(s)

"""The Celery settings DESIGN.md asks for, as the worker really gets them."""

from __future__ import annotations

import pytest
from service_support import deployment, settings_of

from app.core.settings import SettingsError, load_settings
from app.service.broker import broker_options, make_celery


def test_reliability_settings_on_redis(tmp_path, redis_url):
    s = settings_of(deployment(tmp_path, broker=redis_url))
    conf = make_celery(s).conf
    assert conf.task_acks_late and conf.task_reject_on_worker_lost
    assert conf.worker_prefetch_multiplier == 1
    assert conf.worker_max_tasks_per_child == s.worker_max_tasks_per_child
    assert conf.worker_max_memory_per_child == s.worker_max_memory_per_child_mb * 1024
    assert conf.broker_transport_options["visibility_timeout"] > s.max_job_s
    assert conf.broker_transport_options["global_keyprefix"] == redis_url[1]
    assert conf.task_default_queue == s.queue


def test_the_worker_reconnects_for_ever_every_few_seconds(tmp_path, redis_url):
    from app.service.consumer import RECONNECT_MAX_S, ReconnectingConnection

    app = make_celery(settings_of(deployment(tmp_path, broker=redis_url)))
    assert app.conf.broker_connection_max_retries is None  # a worker waits for its broker, however long
    conn = app.connection_for_read()
    assert isinstance(conn, ReconnectingConnection) and isinstance(conn.clone(), ReconnectingConnection)
    assert RECONNECT_MAX_S <= 5  # the queue moves within seconds of the broker's return
    sender = make_celery(settings_of(deployment(tmp_path, broker=redis_url)), sender=True)
    assert not isinstance(sender.connection_for_write(), ReconnectingConnection)  # a sender fails fast instead


def test_embedded_broker_needs_no_server(tmp_path):
    s = settings_of(deployment(tmp_path))
    url, options = broker_options(s)
    assert url == "filesystem://" and options["data_folder_in"] == options["data_folder_out"]
    assert str(s.data_dir.resolve()) in options["data_folder_in"]


@pytest.mark.parametrize("env, name", [
    ({"lease_s": 0}, "GAITMEND_LEASE_S"),
    ({"max_attempts": 0}, "GAITMEND_MAX_ATTEMPTS"),
    ({"broker_url": "amqp://guest@localhost//"}, "GAITMEND_BROKER_URL"),
    ({"database_url": "mysql://x"}, "GAITMEND_DATABASE_URL"),
    ({"auth": "maybe"}, "GAITMEND_AUTH"),
    ({"max_job_s": 50000, "visibility_timeout_s": 40000}, "GAITMEND_VISIBILITY_TIMEOUT_S"),
    ({"redispatch_after_s": 0.5}, "GAITMEND_REDISPATCH_AFTER_S"),
    ({"stop_grace_s": -1}, "GAITMEND_STOP_GRACE_S"),
    ({"stall_after_s": 0}, "GAITMEND_STALL_AFTER_S"),
    ({"min_free_mb": -1}, "GAITMEND_MIN_FREE_MB"),
    ({"space_reserve_mb": 2048}, "GAITMEND_SPACE_RESERVE_MB"),
    ({"storage_wait_s": -1}, "GAITMEND_STORAGE_WAIT_S"),
    ({"bundle_retention_days": -1}, "GAITMEND_BUNDLE_RETENTION_DAYS"),
    ({"checkpoint_retention_days": -1}, "GAITMEND_CHECKPOINT_RETENTION_DAYS"),
    ({"db_retry_s": 120}, "GAITMEND_DB_RETRY_S"),
])
def test_bad_settings_fail_fast_naming_the_variable(env, name):
    with pytest.raises(SettingsError, match=name):
        load_settings(**env)


def test_sqlite_runs_in_wal_with_a_busy_timeout(tmp_path):
    from sqlalchemy import text

    from app.store.db import SQLITE_BUSY_TIMEOUT_MS, session_scope

    url = f"sqlite:///{tmp_path / 'x.db'}"
    with session_scope(url, readonly=True) as s:
        assert s.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert s.execute(text("PRAGMA busy_timeout")).scalar() == SQLITE_BUSY_TIMEOUT_MS

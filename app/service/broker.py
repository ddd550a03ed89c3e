"""The Celery app's configuration and its reliability settings, shared by the senders
(API, housekeeper: app/service/dispatch.py) and the worker (workers/celery_app.py), so that the
service layer never imports the worker package.

The broker only carries job ids; the jobs table is the source of truth (DESIGN.md). Hence:
acks_late + reject_on_worker_lost (a message is only gone once its job ran), prefetch 1
(a busy worker holds no other job's message), a visibility timeout above the longest job
(Redis does not redeliver a running job), and a reaper for what a broker loses on kill -9.
"""

from __future__ import annotations

from celery import Celery
from celery.app.amqp import AMQP

from app.core.settings import Settings, get_settings
from app.service.consumer import ReconnectingConnection


def ensure_broker_folder(settings: Settings) -> None:
    """The embedded broker's folders, made by whoever sends or consumes first (never at
    import: importing this module must not write into the current folder)."""
    if settings.embedded_broker:
        (settings.broker_dir.resolve() / "processed").mkdir(parents=True, exist_ok=True)


# A sender (the API, the housekeeper) must not block a request on an unreachable Redis:
# kombu's default retries a refused connection for ~6 s. It tries once, briefly; the job
# stays queued without a dispatch time and the housekeeper sends it when Redis is back.
SENDER_OPTIONS = {"max_retries": 0, "socket_connect_timeout": 1.0, "socket_timeout": 5.0}


def broker_options(settings: Settings, sender: bool = False) -> tuple[str, dict]:
    if settings.embedded_broker:
        # Celery's filesystem transport: a folder of message files, no server. A message
        # taken by a worker that is then killed is lost; the reaper re-sends it.
        folder = settings.broker_dir.resolve()
        return "filesystem://", {"data_folder_in": str(folder), "data_folder_out": str(folder),
                                 "processed_folder": str(folder / "processed"), "store_processed": False,
                                 # exchange tables; kombu's default is ./control in the cwd
                                 "control_folder": str(folder / "control"),
                                 "polling_interval": settings.poll_interval_s}
    options = {"visibility_timeout": settings.visibility_timeout_s, "global_keyprefix": settings.redis_key_prefix}
    return settings.broker_connection_url, options | (SENDER_OPTIONS if sender else {})


class _WorkerAMQP(AMQP):
    """The worker's broker connections retry every second or so (app/service/consumer.py)."""

    Connection = ReconnectingConnection


def make_celery(settings: Settings | None = None, sender: bool = False) -> Celery:
    """`sender`: an app that only sends job ids (fails fast when the broker is down)."""
    settings = settings or get_settings()
    url, options = broker_options(settings, sender)
    app = Celery("gaitmend", broker=url, include=["workers.tasks"], amqp=None if sender else _WorkerAMQP)
    app.conf.update(
        broker_transport_options=options,
        # A worker whose broker is unreachable at start stops with the reason (and
        # `gaitmend worker` checks first); once running, it reconnects for as long as it
        # takes, every few seconds (app/service/consumer.py), and is not live meanwhile.
        broker_connection_retry_on_startup=False,
        broker_connection_max_retries=None,
        task_default_queue=settings.queue,
        task_acks_late=True,
        task_reject_on_worker_lost=True,
        task_ignore_result=True,
        task_serializer="json",
        accept_content=["json"],
        worker_prefetch_multiplier=1,
        worker_concurrency=settings.worker_concurrency,
        worker_max_tasks_per_child=settings.worker_max_tasks_per_child,
        worker_max_memory_per_child=settings.worker_max_memory_per_child_mb * 1024,  # KiB
        worker_enable_remote_control=False,  # workers report to the database instead
        worker_send_task_events=False,
        worker_hijack_root_logger=False,
        broker_heartbeat=0,
    )
    return app

"""The worker's Celery app (its configuration: app/service/broker.py) and its signal handlers:
a fresh database engine and the stop handler per pool process, the broker folder, the
consumer guard (app/service/consumer.py), the housekeeping thread, the stop."""

from __future__ import annotations

import logging
import threading
import warnings

from celery import signals
from celery.exceptions import CPendingDeprecationWarning

from app.service.broker import ensure_broker_folder, make_celery
from app.service.consumer import CONSUMER, ConsumerGuard, start_shutdown_thread
from app.core.settings import get_settings

log = logging.getLogger("gaitmend.worker")

celery_app = make_celery()
celery_app.steps["consumer"].add(ConsumerGuard)
# On a lost connection Celery warns, every time, that Celery 6 may cancel running acks_late
# tasks; gaitmend keeps them running (worker_cancel_long_running_tasks_on_connection_loss
# stays False: a job outlives a broker blip and its claim fences duplicates).
warnings.filterwarnings("ignore", category=CPendingDeprecationWarning)


@signals.worker_process_init.connect
def _fresh_engine_per_child(**_):
    # A forked pool process must not use connections opened by the parent.
    from app.store.db import forget_engines

    forget_engines()


@signals.worker_init.connect
def _broker_folder(**_):
    ensure_broker_folder(get_settings())


@signals.worker_init.connect
def _preload(**_):
    """Import in the main process what every job's finish needs (bundle, replay, plots) and
    read the versions a bundle records, before the pool forks: each pool process (a new one
    when one is replaced) then starts with them instead of paying ~2 s of
    imports and two git calls in its first job (measured with `python -m app.cli.study_bench`,
    docs/studies.md)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import viser  # noqa: F401  (replay.record imports it lazily: 0.18 s)

    from app.results import bundle, replay  # noqa: F401

    bundle.versions()


_hostname: list[str] = []


@signals.worker_ready.connect
def _start_housekeeping(sender=None, **_):
    from app.service.housekeeping import Housekeeper

    settings = get_settings()
    name = _name(sender)
    _hostname.append(name)
    slots = getattr(getattr(sender, "controller", None), "concurrency", None) or settings.worker_concurrency
    hk = Housekeeper(settings, worker_name=name, live=lambda: CONSUMER.connected and not CONSUMER.stopping,
                     slots=int(slots))
    threading.Thread(target=hk.loop, name="housekeeping", daemon=True).start()


@signals.worker_shutting_down.connect
def _stopping(sender=None, **_):
    """Runs inside the signal handler of the main process: the work goes to a thread."""
    start_shutdown_thread(get_settings(), _hostname[0] if _hostname else str(sender))


def _name(sender) -> str:
    from app.service.runner import worker_name

    return getattr(sender, "hostname", None) or worker_name()

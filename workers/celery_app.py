"""The worker's Celery app (its configuration: app/service/broker.py) and its signal handlers:
a fresh database engine per pool process, the broker folder, the housekeeping thread."""

from __future__ import annotations

import logging
import threading

from celery import signals

from app.service.broker import ensure_broker_folder, make_celery
from app.core.settings import get_settings

log = logging.getLogger("gaitmend.worker")

celery_app = make_celery()


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


@signals.worker_ready.connect
def _start_housekeeping(sender=None, **_):
    from app.service.housekeeping import Housekeeper

    hk = Housekeeper(get_settings(), worker_name=_name(sender))
    threading.Thread(target=hk.loop, name="housekeeping", daemon=True).start()


def _name(sender) -> str:
    from app.service.runner import worker_name

    return getattr(sender, "hostname", None) or worker_name()

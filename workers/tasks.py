"""Tasks: thin. A task takes a job id and hands it to the runner."""

from __future__ import annotations

from app.service.runner import install_stop_handler, run_job as _run_job
from app.core.settings import get_settings
from workers.celery_app import celery_app


@celery_app.task(name="gaitmend.run_job", acks_late=True, reject_on_worker_lost=True)
def run_job(job_id: str) -> str:
    settings = get_settings()
    install_stop_handler()  # SIGTERM hands the job back (app/service/runner.py); once per pool process
    try:
        return _run_job(settings, job_id)
    finally:
        _refill(settings)


def _refill(settings) -> None:
    """A slot is free: send the owners' next queued jobs (fair dispatch, app/studies/fair.py)."""
    import logging

    from app.service.dispatch import refill

    try:
        refill(settings)
    except Exception:  # the housekeeper sends them on its next pass
        logging.getLogger("gaitmend.dispatch").exception("refill after a job failed")

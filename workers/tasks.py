"""Tasks: thin. A task takes a job id and hands it to the runner."""

from __future__ import annotations

from app.runner import run_job as _run_job
from app.settings import get_settings
from workers.celery_app import celery_app


@celery_app.task(name="gaitmend.run_job", acks_late=True, reject_on_worker_lost=True)
def run_job(job_id: str) -> str:
    return _run_job(get_settings(), job_id)

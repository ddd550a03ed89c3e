"""Celery app and tasks of the job service."""

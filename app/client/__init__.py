"""The Python client of a gaitmend server and the result-bundle reader (importable as
``gaitmend``): ``Client`` (jobs and studies, DataFrames, errors with the API's fields) and
``open_bundle``. The CLI's client commands are a thin layer over it (app/cli/client.py)."""

from app.client.bundle_reader import Bundle, Figure, Verification, open_bundle
from app.client.errors import Conflict, GaitmendError, InvalidSpec, NotFound, ServerUnreachable, Unauthorized
from app.client.http import Client
from app.client.jobs import Job, Study

__all__ = ["Bundle", "Client", "Conflict", "Figure", "GaitmendError", "InvalidSpec", "Job", "NotFound",
           "ServerUnreachable", "Study", "Unauthorized", "Verification", "open_bundle"]

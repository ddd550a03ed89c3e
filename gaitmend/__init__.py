"""gaitmend from Python: ``import gaitmend``.

    client = gaitmend.Client()                      # GAITMEND_SERVER / GAITMEND_TOKEN, as the CLI
    job = client.submit({"kind": "recovery", "damage": {"lost_legs": [1, 6]}}).wait()
    job.history.plot(x="generation", y="best")      # pandas
    bundle = gaitmend.open_bundle(job.bundle("."))  # manifest, summary, traces, MjModel, figures

The code lives in the ``app`` package (app/client/); this name is the one to import.
"""

from app import __version__
from app.client import (Bundle, Client, Conflict, Figure, GaitmendError, InvalidSpec, Job, NotFound,
                        ServerUnreachable, Study, Unauthorized, Verification, open_bundle)

__all__ = ["Bundle", "Client", "Conflict", "Figure", "GaitmendError", "InvalidSpec", "Job", "NotFound",
           "ServerUnreachable", "Study", "Unauthorized", "Verification", "__version__", "open_bundle"]

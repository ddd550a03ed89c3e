"""``Client``: the gaitmend HTTP API from Python (a notebook, a script, the CLI client).

    import gaitmend
    client = gaitmend.Client()                 # GAITMEND_SERVER / GAITMEND_TOKEN, as the CLI
    job = client.submit({"kind": "recovery", "damage": {"lost_legs": [1, 6]}})
    job.wait()                                 # a progress bar; returns the finished job
    job.history                                # pandas.DataFrame, one row per generation
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import httpx

from app.client.adaptations import AdaptationsMixin
from app.client.errors import GaitmendError, ServerUnreachable, error_for
from app.client.jobs import FINAL, Job, Study


def _spec_json(spec: Any) -> bytes:
    """A spec as the request body: a dict, a pydantic spec, JSON text, or a path to a spec
    JSON, a bundle's manifest.json or a bundle zip."""
    if hasattr(spec, "model_dump_json"):
        return spec.model_dump_json().encode()
    if isinstance(spec, (str, Path)) and not (isinstance(spec, str) and spec.lstrip().startswith("{")):
        from app.results.bundle import read_spec_file

        return json.dumps(read_spec_file(Path(spec))).encode()
    if isinstance(spec, str):
        return spec.encode()
    return json.dumps(spec, allow_nan=False).encode()


class Client(AdaptationsMixin):
    """One connection to a gaitmend server. ``server`` and ``token`` default to the
    settings the CLI reads (GAITMEND_SERVER, GAITMEND_TOKEN). Every method raises a
    ``GaitmendError`` (``InvalidSpec``, ``NotFound``, ``Conflict``, ...) carrying the API's
    message and its field errors. Use as a context manager, or call ``close()``."""

    def __init__(self, server: str | None = None, token: str | None = None, timeout: float = 30.0):
        if server is None or token is None:
            from app.core.settings import load_settings

            settings = load_settings()
            server = server if server is not None else settings.server
            token = token if token is not None else settings.token
        self.server = server.rstrip("/")
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._http = httpx.Client(base_url=self.server, headers=headers, timeout=timeout)

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def __repr__(self) -> str:
        return f"<gaitmend.Client {self.server}>"

    # -- the wire -----------------------------------------------------------------------------
    def request(self, method: str, url: str, **kw) -> httpx.Response:
        """One API call; an error status raises the matching GaitmendError."""
        try:
            r = self._http.request(method, url, **kw)
        except httpx.HTTPError as e:
            raise ServerUnreachable(None, f"cannot reach {self.server}: {e}") from None
        if r.status_code >= 400:
            try:
                body = r.json()
            except ValueError:
                body = None
            raise error_for(r.status_code, body, r.text)
        return r

    def get_json(self, url: str, **params) -> Any:
        return self.request("GET", url, params={k: v for k, v in params.items() if v is not None}).json()

    # -- jobs -----------------------------------------------------------------------------------
    def submit(self, spec: Any, idempotency_key: str | None = None):
        """Queue a job; returns its ``Job``. The server checks every field (``InvalidSpec``
        names each bad one)."""
        headers = {"Content-Type": "application/json"} | ({"Idempotency-Key": idempotency_key}
                                                          if idempotency_key else {})
        return Job(self, self.request("POST", "/api/jobs", content=_spec_json(spec), headers=headers).json())

    def job(self, job_id: str):
        """A job by its id (or a unique prefix of it, 6 hex digits or more)."""
        return Job(self, self.get_json(f"/api/jobs/{job_id}"))

    def job_pages(self, kind: str | None = None, status: str | None = None, robot: str | None = None,
                  limit: int | None = 50) -> Iterable[dict]:
        """The jobs as the API lists them (dicts, newest first), following the pages up to
        ``limit`` jobs (None: all)."""
        cursor, seen = None, 0
        while True:
            page = self.get_json("/api/jobs", kind=kind, status=status, robot=robot, cursor=cursor,
                                 limit=min(500, limit - seen) if limit else 500)
            for item in page["items"]:
                yield item
                seen += 1
            cursor = page.get("next_cursor")
            if not cursor or (limit and seen >= limit):
                return

    def jobs(self, kind: str | None = None, status: str | None = None, robot: str | None = None,
             limit: int | None = 50):
        """The jobs as a pandas DataFrame, newest first: id, kind, robot, damage, status,
        progress, times, and one column per headline number ("label [unit]")."""
        from app.client.tables import jobs_frame

        return jobs_frame(list(self.job_pages(kind, status, robot, limit)))

    def cancel(self, job_id: str) -> dict:
        return self.request("POST", f"/api/jobs/{job_id}/cancel").json()

    def retry(self, job_id: str) -> dict:
        return self.request("POST", f"/api/jobs/{job_id}/retry").json()

    def delete(self, job_id: str) -> str:
        """Delete a job that is not running (a prefix is resolved first); returns its id."""
        full = self.get_json(f"/api/jobs/{job_id}")["id"]
        self.request("DELETE", f"/api/jobs/{full}")
        return full

    def download(self, url: str, path: Path, timeout: float | None = 600.0) -> Path:
        """Stream a response body into ``path`` (a part file, renamed once complete)."""
        path = Path(path)
        part = path.with_name(path.name + ".part")
        try:
            with self._http.stream("GET", url, timeout=timeout) as r:
                if r.status_code >= 400:
                    r.read()
                    try:
                        body = r.json()
                    except ValueError:
                        body = None
                    raise error_for(r.status_code, body, r.text)
                path.parent.mkdir(parents=True, exist_ok=True)  # only for a body that came
                with open(part, "wb") as f:
                    for chunk in r.iter_bytes():
                        f.write(chunk)
            part.replace(path)
        except httpx.HTTPError as e:
            raise ServerUnreachable(None, f"cannot reach {self.server}: {e}") from None
        finally:
            part.unlink(missing_ok=True)
        return path

    # -- studies ----------------------------------------------------------------------------------
    def submit_study(self, study: Any):
        """Queue a study (a dict, JSON text or a study file); returns its ``Study``."""
        body = _spec_json(study) if not isinstance(study, (str, Path)) or str(study).lstrip().startswith("{") \
            else Path(study).read_bytes()
        return Study(self, self.request("POST", "/api/studies", content=body,
                                        headers={"Content-Type": "application/json"}).json())

    def study(self, study_id: str):
        return Study(self, self.get_json(f"/api/studies/{study_id}"))

    def studies(self, limit: int = 50):
        """The studies as a DataFrame: id, name, status, progress, created."""
        from app.client.tables import studies_frame

        return studies_frame(self.get_json("/api/studies", limit=limit)["items"])

    def builtin_studies(self) -> list[dict]:
        return self.get_json("/api/studies/builtin")["items"]

    # -- waiting ----------------------------------------------------------------------------------
    def poll(self, url: str, done: Callable[[dict], bool], on_update: Callable[[dict], None] | None = None,
             timeout: float | None = None, interval: float = 0.5) -> dict:
        """GET ``url`` until ``done(body)``; ``on_update(body)`` after each read. Raises
        TimeoutError after ``timeout`` seconds."""
        t0 = time.monotonic()
        while True:
            body = self.get_json(url)
            if on_update is not None:
                on_update(body)
            if done(body):
                return body
            if timeout is not None and time.monotonic() - t0 > timeout:
                raise TimeoutError(f"{url} not finished after {timeout:g} s")
            time.sleep(interval)


__all__ = ["Client", "GaitmendError", "FINAL"]

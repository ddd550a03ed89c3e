"""The errors the Python client raises: the API's own status, message and field errors."""

from __future__ import annotations


class GaitmendError(Exception):
    """A request the server refused, or a server that could not be reached.

    ``status``: the HTTP status (None when nothing answered); ``detail``: the API's message;
    ``errors``: the API's [{"field", "message"}] list (one entry per bad field of a spec);
    ``field`` and ``message``: those of the first error."""

    def __init__(self, status: int | None, detail: str, errors: list[dict[str, str]] | None = None):
        self.status, self.detail = status, detail
        self.errors = list(errors or [])
        super().__init__(self._text())

    def _text(self) -> str:
        where = f"HTTP {self.status}: " if self.status else ""
        fields = "; ".join(f"{e.get('field', '?')}: {e.get('message', '')}" for e in self.errors)
        return where + (fields or self.detail)

    @property
    def field(self) -> str | None:
        return self.errors[0].get("field") if self.errors else None

    @property
    def message(self) -> str:
        return self.errors[0].get("message", self.detail) if self.errors else self.detail

    @property
    def fields(self) -> dict[str, str]:
        """{field: message} of every error."""
        return {e.get("field", ""): e.get("message", "") for e in self.errors}


class InvalidSpec(GaitmendError):
    """422: the spec (or a query parameter) is not acceptable; ``errors`` names each field."""


class NotFound(GaitmendError):
    """404: no such job or study (or not yours)."""


class Conflict(GaitmendError):
    """409: not in a state for that (a bundle before the job succeeded, a retry of a success...)."""


class Unauthorized(GaitmendError):
    """401: a token is required (GAITMEND_TOKEN, or Client(token=...))."""


class ServerUnreachable(GaitmendError):
    """Nothing answered at the server's address."""


_BY_STATUS = {401: Unauthorized, 404: NotFound, 409: Conflict, 422: InvalidSpec}


def error_for(status: int, body: object, text: str) -> GaitmendError:
    """The exception for an error response: the API's body is {"detail", "errors"}."""
    detail, errors = text, []
    if isinstance(body, dict):
        detail = str(body.get("detail", text))
        raw = body.get("errors")
        if isinstance(raw, list):
            errors = [{"field": str(e.get("field", "")), "message": str(e.get("message", ""))}
                      for e in raw if isinstance(e, dict)]
    return _BY_STATUS.get(status, GaitmendError)(status, detail, errors)

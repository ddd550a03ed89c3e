"""The one error an upload is refused with."""

from __future__ import annotations


class RefusedUpload(ValueError):
    """An upload that will not be stored. The message names what was refused (an element,
    an attribute, a file name as the upload gave it, a cap) and never anything of the host:
    no file of the host is ever opened for an upload, so its text cannot depend on whether
    a host path exists. `field` is the part of the request at fault."""

    def __init__(self, message: str, field: str = "model", status: int = 422):
        super().__init__(message)
        self.field, self.status = field, status

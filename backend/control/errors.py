"""The one error every command raises, whichever entry point sent it."""

from __future__ import annotations

from typing import Any

from backend.errors import DomainError


class CommandError(DomainError):
    """A command that is malformed or cannot be carried out; `field` names the culprit.

    `code` is the error code clients see: `invalid_command` (malformed), `no_target` (the running
    program has nothing to carry it out), `ambiguous_target`, `invalid_input`, `rejected` (the target
    block said no), `busy` (the target plays another command's action and the command said `reject`),
    `unknown_command` (a cancel for an id nobody sent), or a JSON-safety code. Which status an edge
    answers a code with is the edge's business (backend/routes/errors.py).
    """

    def __init__(self, message: str, field: str | None = None, code: str = "invalid_command", **extra: Any):
        super().__init__(message, code=code, field=field, **extra)

    @property
    def detail(self) -> dict[str, Any]:
        # A command error always names its field, null when the command as a whole is at fault: the
        # contract's command errors have carried the key from the start.
        return {"code": self.code, "message": self.message, "field": self.field, **self.extra}

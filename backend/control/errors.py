"""The one error every command raises, whichever entry point sent it."""

from __future__ import annotations

NOT_FOUND_CODES = frozenset({"no_target", "unknown_command"})  # answered 404 rather than 422
CONFLICT_CODES = frozenset({"busy"})  # answered 409: the target is doing something else now


class CommandError(ValueError):
    """A command that is malformed or cannot be carried out; `field` names the culprit.

    `code` is the error code clients see: `invalid_command` (malformed), `no_target` (the running
    program has nothing to carry it out), `ambiguous_target`, `invalid_input`, `rejected` (the target
    block said no), `busy` (the target plays another command's action and the command said `reject`),
    `unknown_command` (a cancel for an id nobody sent), or a JSON-safety code.
    """

    def __init__(self, message: str, field: str | None = None, code: str = "invalid_command"):
        super().__init__(message)
        self.field = field
        self.code = code

    @property
    def not_found(self) -> bool:
        """Whether the command named something that is not there (HTTP 404 rather than 422)."""
        return self.code in NOT_FOUND_CODES

    @property
    def http_status(self) -> int:
        """The HTTP status a server answers this error with: 404, 409 or 422."""
        return 404 if self.not_found else 409 if self.code in CONFLICT_CODES else 422

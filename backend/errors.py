"""The one error the core raises when a request cannot be carried out, whichever edge it came through.

The core (engine, graph, control, session, hub) knows nothing of HTTP or Zenoh: it raises a
`DomainError` with a `code` clients can act on, the `field` at fault and any extra detail. The edges
answer it in the contract's error shape (docs/api-contract.md); the HTTP status for a code is the
edges' business (backend/routes/errors.py, also used for the Zenoh link's reply status). Clients see
the same code again as `backend.client.NuttyError`.
"""

from __future__ import annotations

from typing import Any


class DomainError(ValueError):
    """A request the core refuses. `code` is what clients see (`no_target`, `busy`, `invalid_program`,
    ...), `field` names the culprit (None: the request as a whole), `extra` is more detail for the
    answer (a command's `id`, a program's `report`), each a JSON value.

    A ValueError, so code written for the plain ValueErrors the core raised before still catches it.
    """

    def __init__(self, message: str, *, code: str = "invalid", field: str | None = None, **extra: Any):
        super().__init__(message)
        self.code = code
        self.field = field
        self.extra = extra

    @property
    def message(self) -> str:
        return str(self)

    @property
    def detail(self) -> dict[str, Any]:
        """The contract's error object: `{"code", "message", "field"?, ...extra}` (`field` when named)."""
        out: dict[str, Any] = {"code": self.code, "message": self.message}
        if self.field is not None:
            out["field"] = self.field
        out.update(self.extra)
        return out

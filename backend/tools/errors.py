"""The error a tool call answers with when its name or arguments are wrong: it names the field."""

from __future__ import annotations


class ToolError(ValueError):
    """A tool call that cannot be carried out; `field` names the argument at fault. `status` is the HTTP
    status the server answers with (404 for a tool that is not offered, 422 for a bad argument)."""

    def __init__(
        self, message: str, field: str | None = None, code: str = "invalid_argument", status: int = 422
    ):
        super().__init__(message)
        self.field = field
        self.code = code
        self.status = status

    def detail(self) -> dict:
        return {"code": self.code, "message": str(self), **({"field": self.field} if self.field else {})}

"""Errors in the contract's one shape, `{"detail": {"code", "message", "field"?, ...}}`, never a traceback.

The core raises `DomainError` (backend.errors) with a code; `http_status` is the one table from code to
HTTP status, used by the app's handler here and for the Zenoh link's reply status
(backend/zenoh_link/engine.py). Errors that only an HTTP request can have (a body's media type, its
size, a proxied page) are raised here with their status (`api_error`).
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException

from backend import security
from backend.errors import DomainError

# Codes answered with something other than 422 (the request is understood but refused).
NOT_FOUND_CODES = frozenset(
    {
        "no_target",  # a command's target: the running program has nothing to carry it out
        "unknown_command",  # a command id nobody sent
        "no_program",
        "unknown_node",
        "unknown_block_type",
        "not_found",  # a library asset
        "no_urdf",
        "no_visuals",
        "no_previz",
    }
)
CONFLICT_CODES = frozenset(
    {
        "busy",  # the target plays another command's action and the command said `reject`
        "duplicate_id",  # the id of a command still running
    }
)


def http_status(exc: DomainError) -> int:
    """The HTTP status for a refused request: 404 when what it names is not there, 409 when it
    conflicts with what runs now, else 422."""
    if exc.code in NOT_FOUND_CODES:
        return 404
    return 409 if exc.code in CONFLICT_CODES else 422


def error_detail(exc: DomainError, **extra: Any) -> dict[str, Any]:
    """`exc`'s error object, its message safe to encode, with `extra` (e.g. a command's `id`) added."""
    detail = {**exc.detail, **extra}
    detail["message"] = security.safe_text(detail["message"])
    return detail


def api_error(status: int, code: str, message: str, **extra: Any) -> HTTPException:
    """An HTTPException whose detail is the contract's error object (`extra`: field, report, id, ...)."""
    return HTTPException(
        status_code=status, detail={"code": code, "message": security.safe_text(message), **extra}
    )


class SafeJSONResponse(JSONResponse):
    """JSON that always renders: NaN and lone surrogates are sanitised instead of raising (a 500)."""

    def render(self, content: Any) -> bytes:
        return security.dumps(content).encode("utf-8")


def validation_detail(exc: RequestValidationError) -> dict[str, Any]:
    """A 422's detail: a body that does not fit its model is `invalid_body` naming the field (the body
    was JSON-safe already, see json_body); a bad path or query parameter is `invalid_request`."""
    errors = [
        {
            "loc": [security.safe_text(x) for x in e.get("loc", ())],
            "msg": security.safe_text(e.get("msg", "")),
            "type": e.get("type"),
        }
        for e in exc.errors()
    ]
    first = errors[0] if errors else {"loc": [], "msg": "invalid request"}
    field = ".".join(str(x) for x in first["loc"][1:]) or None
    if first["loc"][:1] == ["body"]:
        return {"code": "invalid_body", "message": f"{field or 'body'}: {first['msg']}", "field": field}
    return {
        "code": "invalid_request",
        "message": f"{field or 'request'}: {first['msg']}",
        "field": field,
        "errors": errors,
    }


def install_error_handlers(app: FastAPI) -> None:
    """Every error the app answers is JSON in the contract's shape; an unexpected one a bare 500."""

    @app.exception_handler(StarletteHTTPException)
    async def http_error(_: Request, exc: StarletteHTTPException) -> Response:
        detail = (
            exc.detail
            if isinstance(exc.detail, dict)
            else {"code": str(exc.detail or "error").lower().replace(" ", "_"), "message": str(exc.detail)}
        )
        return SafeJSONResponse({"detail": detail}, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(DomainError)
    async def refused(_: Request, exc: DomainError) -> Response:
        return SafeJSONResponse({"detail": error_detail(exc)}, status_code=http_status(exc))

    @app.exception_handler(RequestValidationError)
    async def request_error(_: Request, exc: RequestValidationError) -> Response:
        return SafeJSONResponse({"detail": validation_detail(exc)}, status_code=422)

    @app.exception_handler(Exception)
    async def unexpected_error(_: Request, exc: Exception) -> Response:
        return SafeJSONResponse(
            security.error_body("internal_error", "the server could not handle this request"), status_code=500
        )

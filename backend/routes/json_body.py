"""JSON request bodies, read the server's way before FastAPI validates them.

For every route that takes a body (`SafeJsonRoute`, the route class of every router), the body must
be declared `application/json` (else 415), is counted as it streams in and stopped at MAX_BODY
(413), must not be empty (400) and is parsed by `backend.security.loads` (NaN/inf, huge integers,
invalid Unicode, deep nesting: 400 naming the field). FastAPI then validates the parsed document
against the body's declared type, which is also what OpenAPI shows.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import Request, Response
from fastapi.routing import APIRoute

from backend import security
from backend.routes.errors import api_error
from backend.security import MAX_BODY, JsonSafetyError


async def read_json(request: Request) -> tuple[bytes, Any]:
    """The request's body and its JSON: declared application/json, streamed under the size limit,
    parsed safely. Raises the contract's 4xx errors."""
    problem = security.content_type_problem(request.headers.get("content-type"))
    if problem is not None:
        raise api_error(415, "unsupported_media_type", problem)
    chunks, size = [], 0
    try:
        async for chunk in request.stream():
            size += len(chunk)
            if size > MAX_BODY:
                raise api_error(413, "too_large", f"request body over {MAX_BODY} bytes")
            chunks.append(chunk)
    except security.BodyTooLarge:
        raise api_error(413, "too_large", f"request body over {MAX_BODY} bytes") from None
    raw = b"".join(chunks)
    if not raw.strip():
        raise api_error(400, "malformed_json", "the body is empty: send a JSON document")
    try:
        return raw, security.loads(raw)
    except JsonSafetyError as exc:
        raise api_error(exc.status, exc.code, str(exc), field=exc.field) from exc


class _ParsedRequest(Request):
    """A request whose body was read and parsed already: FastAPI gets the safe parse, not its own."""

    def __init__(self, request: Request, raw: bytes, doc: Any):
        super().__init__(request.scope, request.receive)
        self._raw, self._doc = raw, doc

    async def body(self) -> bytes:
        return self._raw

    async def json(self) -> Any:
        return self._doc


class SafeJsonRoute(APIRoute):
    """An APIRoute whose JSON body (if it takes one) is read by `read_json` before FastAPI sees it.

    Its answer is checked against its `response_model` (backend.api_types) and carries exactly the keys
    the handler gave: a model's optional fields describe keys that may be there, they are never added
    as nulls (handlers return plain JSON documents, so every key they set counts as set)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["response_model_exclude_unset"] = True
        super().__init__(*args, **kwargs)

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()
        if self.body_field is None:
            return handler

        async def parse_then_handle(request: Request) -> Response:
            raw, doc = await read_json(request)
            return await handler(_ParsedRequest(request, raw, doc))

        return parse_then_handle

"""The bearer token in front of `nutty mcp --http`: the MCP endpoint moves the robot as its REST API
does, so it asks for the same token (`--token` / NUTTY_TOKEN) as `nutty serve`. A request without it,
or with another, gets 401 and reaches nothing.
"""

from __future__ import annotations

import hmac
import json
from typing import Any


class TokenGuard:
    """ASGI middleware: HTTP requests must carry `Authorization: Bearer <token>`."""

    def __init__(self, app: Any, token: str):
        self.app = app
        self.expected = f"Bearer {token}".encode()

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        given = dict(scope.get("headers") or []).get(b"authorization", b"")
        if hmac.compare_digest(given, self.expected):
            await self.app(scope, receive, send)
            return
        body = json.dumps(
            {"error": "unauthorized", "message": "send 'Authorization: Bearer <token>' (the robot's --token)"}
        ).encode()
        headers = [(b"content-type", b"application/json"), (b"www-authenticate", b'Bearer realm="nutty"')]
        await send({"type": "http.response.start", "status": 401, "headers": headers})
        await send({"type": "http.response.body", "body": body})

"""The running `nutty serve` an MCP server speaks for: its tools and resources over REST, its events
over /ws/control. Every answer is JSON; a refusal keeps the server's error (`code`, `message`, `field`).
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import httpx

log = logging.getLogger(__name__)
HTTP_TIMEOUT = 10.0  # s, for every request that does not wait for an action
WAIT_MARGIN = 10.0  # s added to a waiting tool call's own timeout
RECONNECT = (0.5, 5.0)  # s: first and longest pause before /ws/control is dialled again


@dataclass
class Answer:
    """A server's answer: `ok` (2xx), the HTTP status, and the JSON body (on an error, its `detail`)."""

    ok: bool
    status: int
    body: Any


class Remote:
    """REST and /ws/control of one Nutty server at `url` (with its `token`, when it has one)."""

    def __init__(self, url: str, token: str | None = None):
        self.url = url.rstrip("/")
        self.token = token
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.AsyncClient(base_url=self.url, headers=headers, timeout=HTTP_TIMEOUT)

    async def close(self) -> None:
        await self.http.aclose()

    async def request(self, method: str, path: str, *, timeout: float = HTTP_TIMEOUT, **kw: Any) -> Answer:
        """One request; a server that cannot be reached is an Answer with status 0 saying so."""
        try:
            r = await self.http.request(method, path, timeout=timeout, **kw)
        except httpx.HTTPError as exc:
            message = f"the Nutty server at {self.url} did not answer ({type(exc).__name__}: {exc})"
            return Answer(False, 0, {"code": "unreachable", "message": message})
        try:
            body = r.json()
        except ValueError:
            body = {"code": "bad_answer", "message": r.text[:500]}
        if r.status_code >= 400:
            detail = body.get("detail") if isinstance(body, dict) else None
            return Answer(
                False,
                r.status_code,
                detail if isinstance(detail, dict) else {"code": "error", "message": str(body)},
            )
        return Answer(True, r.status_code, body)

    async def tools(self) -> Answer:
        """The tools in the plain format (GET /api/tools)."""
        return await self.request("GET", "/api/tools")

    async def call(self, name: str, arguments: dict[str, Any]) -> Answer:
        """Carry out one tool call (POST /api/tools/{name}); a waiting call may take its `timeout`."""
        wait = arguments.get("timeout", 30.0) if arguments.get("wait") is True else 0.0
        wait = float(wait) if isinstance(wait, (int, float)) and not isinstance(wait, bool) else 30.0
        return await self.request(
            "POST",
            f"/api/tools/{name}",
            json=arguments,
            timeout=HTTP_TIMEOUT + WAIT_MARGIN + max(0.0, min(wait, 600.0)),
        )

    async def watch(self, on_event: Callable[[dict[str, Any]], Awaitable[None]]) -> None:
        """Hand every /ws/control event to `on_event`, for ever: a lost connection is dialled again
        (with a growing pause), and each reconnection counts as a possible change (`reconnected`)."""
        from websockets.asyncio.client import connect  # the watcher's alone
        from websockets.exceptions import WebSocketException  # the watcher's alone

        ws_url = "ws" + self.url[len("http") :] + "/ws/control" if self.url.startswith("http") else self.url
        headers = {"Authorization": f"Bearer {self.token}"} if self.token else {}
        pause = RECONNECT[0]
        first = True
        while True:
            try:
                async with connect(ws_url, additional_headers=headers, open_timeout=HTTP_TIMEOUT) as ws:
                    pause = RECONNECT[0]
                    if not first:  # events were missed meanwhile: the tools may have changed
                        await on_event({"type": "event", "event": "reconnected", "id": None})
                    first = False
                    async for text in ws:
                        message = json.loads(text)
                        if isinstance(message, dict) and message.get("type") == "event":
                            await on_event(message)
            except asyncio.CancelledError:
                raise
            except (
                OSError,
                TimeoutError,
                ValueError,
                WebSocketException,
            ) as exc:  # refused, closed, malformed
                log.info("/ws/control of %s: %s; retrying in %.1f s", self.url, exc, pause)
            except Exception:  # a bug must not end the watch: the tools would never be refreshed again
                log.exception("watching /ws/control of %s failed; retrying in %.1f s", self.url, pause)
            await asyncio.sleep(pause)
            pause = min(pause * 2, RECONNECT[1])

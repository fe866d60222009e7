"""One accepted WebSocket: serialised, never-failing sends, and the race of its loops against the
client's disconnect and the app's shutdown, so no task, sink or client count outlives its client."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from fastapi import WebSocket

from backend import security
from backend.security import MAX_WS_MESSAGE, JsonSafetyError, cancel_all

log = logging.getLogger(__name__)


class ClientSocket:
    """A WebSocket client of the server (/ws/control, /ws/telemetry, /ws/frames)."""

    def __init__(self, ws: WebSocket, stopping: asyncio.Event | None):
        self.ws = ws
        self.stopping = stopping
        self._lock = asyncio.Lock()

    async def send(self, message: dict[str, Any]) -> None:
        async with self._lock:
            await self.ws.send_text(security.dumps(message))

    async def send_text(self, text: str) -> None:
        """Send JSON text already encoded (by `security.dumps`)."""
        async with self._lock:
            await self.ws.send_text(text)

    async def send_bytes(self, data: bytes) -> None:
        async with self._lock:
            await self.ws.send_bytes(data)

    async def error(self, code: str, message: str, **extra: Any) -> None:
        await self.send({"type": "error", "code": code, "message": security.safe_text(message), **extra})

    async def messages(self, handle: Callable[[Any], Awaitable[None]]) -> None:
        """Receive until the client leaves: each JSON message goes to `handle`; a binary, oversized,
        malformed or unsafe one, or one whose handling fails, is answered with an error instead."""
        while True:
            message = await self.ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            text = message.get("text")
            if text is None:
                await self.error("binary_message", "this socket takes JSON text messages, not binary ones")
                continue
            if len(text) > MAX_WS_MESSAGE:
                await self.error("too_large", f"message over {MAX_WS_MESSAGE} bytes")
                continue
            try:
                data = security.loads(text, max_bytes=None)
            except JsonSafetyError as exc:
                await self.error(exc.code, str(exc), field=exc.field)
                continue
            try:
                await handle(data)
            except Exception:  # never let one message take the socket down
                log.exception("%s: handling a message failed", self.ws.url.path)
                await self.error("internal_error", "the server could not handle this message")

    async def run(self, receiver: Awaitable[None], sender: Awaitable[None] | None = None) -> None:
        """Race the receive loop, the send loop and the app's shutdown; the first to end ends all."""
        tasks: list[asyncio.Future[Any]] = [asyncio.ensure_future(receiver)]
        if sender is not None:
            tasks.append(asyncio.ensure_future(sender))
        if self.stopping is not None:
            tasks.append(asyncio.ensure_future(self.stopping.wait()))
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            await cancel_all(tasks)
        if self.stopping is not None and self.stopping.is_set():
            try:
                await self.ws.close(code=1001, reason="server shutting down")
            except Exception:  # the client may have gone meanwhile: nothing left to tell it
                log.debug("closing %s at shutdown failed", self.ws.url.path, exc_info=True)

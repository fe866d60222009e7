"""The proxy the API serves at /previz/: viser's page and its WebSocket, from the Pre-Viz's loopback port.

Browsers never reach viser directly: its port listens on 127.0.0.1 only (backend/previz.py), and the
API forwards its files (`fetch_page`) and relays its WebSocket (`relay_socket`) behind the API's own
Origin/Host checks and token. The relay tells viser it came through the proxy with `PROXY_HEADER`
(carrying the Pre-Viz's secret), so gaze drags through it count.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

from backend.security import cancel_all as _cancel_all

if TYPE_CHECKING:  # a cycle at run time: backend.previz re-exports this module
    from backend.previz import PreViz

log = logging.getLogger(__name__)

PROXY_HEADER = "X-Nutty-Previz-Proxy"
MAX_PAGE = 64 * 1024 * 1024  # bytes of one proxied file (viser's page is about 1 MB)
MAX_PREVIZ_MESSAGE = 64 * 1024 * 1024  # bytes of one relayed WebSocket message

# The page embedded in the editor (`/previz/?embed=1`) hides viser's own control panel (a floating dock
# window: the editor has the ghost toggle) and its notifications (e.g. "Software WebGL rendering
# detected"), which would cover the robot in a small pane. The popped-out page keeps them.
EMBED_STYLE = (
    b'<style id="nutty-embed">[data-floating-window], .mantine-Notifications-root '
    b"{ display: none !important; }</style>"
)


def embed_page(html: bytes) -> bytes:
    """viser's index page with EMBED_STYLE in its head (unchanged when it has no </head>)."""
    head = html.find(b"</head>")
    return html if head < 0 else html[:head] + EMBED_STYLE + html[head:]


# viser's page builds its WebSocket URL from the page's own URL without the query: /previz/?token=T
# connects to ws://host/previz, which carries the cookie the page response set (see
# backend.security.previz_cookie_value).


async def fetch_page(
    port: int, path: str, accept_encoding: str = "", timeout: float = 20.0
) -> tuple[int, dict[str, str], bytes]:
    """GET one file of viser's client from its loopback port: (status, headers to pass on, body)."""
    target = "/" + quote(path.lstrip("/"), safe="/._-~")
    reader, writer = await asyncio.wait_for(asyncio.open_connection("127.0.0.1", port), timeout)
    try:
        encoding = "gzip" if "gzip" in accept_encoding.lower() else "identity"
        writer.write(
            (
                f"GET {target} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nAccept-Encoding: {encoding}\r\n"
                f"Connection: close\r\n\r\n"
            ).encode("latin-1")
        )
        await writer.drain()
        head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), timeout)
        lines = head.decode("latin-1").split("\r\n")
        parts = lines[0].split(" ", 2)
        if len(parts) < 2 or not parts[1].isdigit():
            raise ValueError("malformed response from the Pre-Viz")
        status = int(parts[1])
        headers: dict[str, str] = {}
        for line in lines[1:]:
            name, sep, value = line.partition(":")
            if sep:
                headers[name.strip().lower()] = value.strip()
        length = headers.get("content-length")
        if length is not None and length.isdigit():
            if int(length) > MAX_PAGE:
                raise ValueError("response too large")
            body = await asyncio.wait_for(reader.readexactly(int(length)), timeout)
        else:
            body = await asyncio.wait_for(reader.read(MAX_PAGE), timeout)
    finally:
        writer.close()
        with contextlib.suppress(Exception):  # the page is read; how the socket ends changes nothing
            await writer.wait_closed()
    keep = {k: headers[k] for k in ("content-type", "content-encoding") if k in headers}
    keep["cache-control"] = "no-store"
    return status, keep, body


async def relay_socket(ws: Any, previz: PreViz, stopping: asyncio.Event | None) -> None:
    """Relay a browser's Pre-Viz WebSocket (a Starlette WebSocket, already past the API's guard) to
    viser on loopback, both ways, until either side leaves or the app shuts down."""
    from websockets.asyncio.client import connect  # heavy: only where used
    from websockets.exceptions import WebSocketException  # heavy: only where used
    from websockets.typing import Subprotocol  # heavy: only where used

    offered = [p for p in (ws.scope.get("subprotocols") or []) if p.startswith("viser-")]
    try:
        upstream = await connect(
            f"ws://127.0.0.1:{previz.port}",
            subprotocols=[Subprotocol(p) for p in offered] or None,
            additional_headers={PROXY_HEADER: previz.proxy_secret},
            max_size=MAX_PREVIZ_MESSAGE,
            compression=None,
            open_timeout=10,
            ping_interval=None,
        )
    except Exception as exc:  # the browser is told (1011) whatever kept viser from answering
        if isinstance(exc, (OSError, TimeoutError, WebSocketException)):  # down, busy or restarting
            log.info("the Pre-Viz at 127.0.0.1:%s did not answer: %s", previz.port, exc)
        else:
            log.warning("relaying to the Pre-Viz at 127.0.0.1:%s failed", previz.port, exc_info=True)
        await ws.accept(subprotocol=offered[0] if offered else None)
        await ws.close(code=1011, reason="the Pre-Viz is not available")
        return
    try:
        await ws.accept(subprotocol=upstream.subprotocol)

        async def to_upstream() -> None:
            while True:
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    return
                data = message.get("bytes")
                await upstream.send(data if data is not None else message.get("text") or "")

        async def to_client() -> None:
            async for data in upstream:
                if isinstance(data, bytes):
                    await ws.send_bytes(data)
                else:
                    await ws.send_text(data)

        tasks: list[asyncio.Future[Any]] = [
            asyncio.ensure_future(to_upstream()),
            asyncio.ensure_future(to_client()),
        ]
        if stopping is not None:
            tasks.append(asyncio.ensure_future(stopping.wait()))
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            await _cancel_all(tasks)
    finally:
        # either side may have gone already (that is often why the relay ends): closing is best effort
        with contextlib.suppress(Exception):
            await upstream.close()
        with contextlib.suppress(Exception):
            await ws.close()

"""Talking to a running `nutty serve` with the standard library only: JSON over HTTP, and a small
WebSocket client (RFC 6455, text frames) for /ws/control.

Every failure is a `NuttyError` whose message says what went wrong and what to do, in words an
animator can act on (the add-on's operators show it as Blender's report, never a traceback).
"""

from __future__ import annotations

import base64
import contextlib
import hashlib
import json
import os
import socket
import struct
import urllib.error
import urllib.parse
import urllib.request
from typing import Any

DEFAULT_URL = "http://127.0.0.1:8000"
_WS_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


class NuttyError(Exception):
    """A request to the server failed; the message is meant for Blender's report. `status`: the HTTP
    status of a refused request (else None), `field`: the request field the server named (else None)."""

    def __init__(self, message: str, status: int | None = None, field: str | None = None):
        super().__init__(message)
        self.status, self.field = status, field


def _detail(body: bytes) -> tuple[str, str | None]:
    """The server's error message and field from its `{"detail": {...}}` body (or the raw text)."""
    try:
        detail = json.loads(body.decode("utf-8")).get("detail")
    except (ValueError, AttributeError, UnicodeDecodeError):
        return body.decode("utf-8", "replace")[:200].strip(), None
    if isinstance(detail, dict):
        return str(detail.get("message") or detail.get("code") or "error"), detail.get("field")
    return str(detail), None


class Client:
    """A Nutty server at `url` (http://host:port), with its token if it has one.

    `timeout` (s) bounds every request; a slow server is an error, never a frozen Blender.
    """

    def __init__(self, url: str = DEFAULT_URL, token: str = "", timeout: float = 10.0):
        url = (url or DEFAULT_URL).strip().rstrip("/")
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise NuttyError(f"the server address '{url}' is not an http:// URL (e.g. {DEFAULT_URL})")
        self.url = url
        self.token = (token or os.environ.get("NUTTY_TOKEN", "")).strip()
        self.timeout = timeout
        self.loopback = parts.hostname in ("localhost", "127.0.0.1", "::1") or parts.hostname.startswith(
            "127."
        )

    # --- HTTP ---------------------------------------------------------------------------------------
    def request(self, method: str, path: str, body: Any = None) -> bytes:
        """The response body of `method path` (JSON `body` if given); NuttyError otherwise."""
        data = None if body is None else json.dumps(body, allow_nan=False).encode("utf-8")
        req = urllib.request.Request(self.url + path, data=data, method=method)
        if data is not None:
            req.add_header("Content-Type", "application/json")
        if self.token:
            req.add_header("Authorization", f"Bearer {self.token}")
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as resp:
                return resp.read()
        except urllib.error.HTTPError as exc:
            message, field = _detail(exc.read())
            if exc.code == 401:
                raise NuttyError(
                    f"the server at {self.url} needs its token: set it in the Nutty panel ({message})"
                ) from None
            where = f" ({field})" if field else ""
            raise NuttyError(
                f"the server refused {method} {path}: {message}{where}", status=exc.code, field=field
            ) from None
        except urllib.error.URLError as exc:
            reason = getattr(exc, "reason", exc)
            raise NuttyError(
                f"cannot reach nutty serve at {self.url}: {reason}. Is `nutty serve` running "
                f"there? (Nutty panel: server address)"
            ) from None
        except TimeoutError:
            raise NuttyError(
                f"nutty serve at {self.url} did not answer {method} {path} within {self.timeout:g} s"
            ) from None
        except (ConnectionError, OSError) as exc:
            raise NuttyError(f"the connection to nutty serve at {self.url} failed: {exc}") from None

    def json(self, method: str, path: str, body: Any = None) -> Any:
        raw = self.request(method, path, body)
        try:
            return json.loads(raw.decode("utf-8")) if raw else None
        except (ValueError, UnicodeDecodeError):
            raise NuttyError(f"{self.url}{path} did not answer with JSON: is this a nutty serve?") from None

    def get(self, path: str) -> Any:
        return self.json("GET", path)

    def post(self, path: str, body: Any) -> Any:
        return self.json("POST", path, body)

    def put(self, path: str, body: Any) -> Any:
        return self.json("PUT", path, body)

    # --- WebSocket ----------------------------------------------------------------------------------
    def websocket(self, path: str) -> WebSocket:
        return WebSocket(self, path)


class WebSocket:
    """A client WebSocket (text frames) to `client`'s server at `path`, e.g. /ws/control.

    `send(obj)` sends one JSON message; `receive(timeout)` returns the next JSON message or None when
    none arrives in time; `close()` ends it. Errors are NuttyError.
    """

    def __init__(self, client: Client, path: str):
        parts = urllib.parse.urlsplit(client.url)
        host, port = parts.hostname, parts.port or (443 if parts.scheme == "https" else 80)
        if parts.scheme == "https":
            raise NuttyError("the live link needs a plain http:// server address (no TLS)")
        self.where = f"{client.url}{path}"
        try:
            self.sock = socket.create_connection((host, port), timeout=client.timeout)
        except OSError as exc:
            raise NuttyError(
                f"cannot reach nutty serve at {client.url}: {exc}. Is `nutty serve` running?"
            ) from None
        key = base64.b64encode(os.urandom(16)).decode()
        lines = [
            f"GET {path} HTTP/1.1",
            f"Host: {parts.netloc}",
            "Upgrade: websocket",
            "Connection: Upgrade",
            f"Sec-WebSocket-Key: {key}",
            "Sec-WebSocket-Version: 13",
        ]
        if client.token:
            lines.append(f"Authorization: Bearer {client.token}")
        self._buffer = b""
        try:
            self.sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
            head = self._read_until(b"\r\n\r\n").decode("latin-1")
        except OSError as exc:
            self.sock.close()
            raise NuttyError(f"the WebSocket handshake with {self.where} failed: {exc}") from None
        status = head.split("\r\n", 1)[0]
        expected = base64.b64encode(hashlib.sha1((key + _WS_GUID).encode()).digest()).decode()
        if " 101 " not in status + " " or expected not in head:
            self.sock.close()
            raise NuttyError(f"{self.where} did not accept a WebSocket ({status.strip()})")
        self.closed = False
        self.close_reason = ""

    def _read_until(self, marker: bytes) -> bytes:
        while marker not in self._buffer:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("the server closed the connection")
            self._buffer += chunk
        head, _, self._buffer = self._buffer.partition(marker)
        return head

    def _send_frame(self, opcode: int, payload: bytes) -> None:
        header = bytes([0x80 | opcode])
        n = len(payload)
        if n < 126:
            header += bytes([0x80 | n])
        elif n < 65536:
            header += bytes([0x80 | 126]) + struct.pack("!H", n)
        else:
            header += bytes([0x80 | 127]) + struct.pack("!Q", n)
        mask = os.urandom(4)  # a client masks every frame (RFC 6455 5.3)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(header + mask + masked)

    def send(self, message: Any) -> None:
        if self.closed:
            raise NuttyError(
                f"the connection to {self.where} is closed ({self.close_reason or 'by the server'})"
            )
        try:
            self._send_frame(0x1, json.dumps(message, allow_nan=False).encode("utf-8"))
        except OSError as exc:
            self.closed, self.close_reason = True, str(exc)
            raise NuttyError(f"the connection to {self.where} dropped: {exc}") from None

    def _frame(self) -> tuple[int, bytes] | None:
        """(opcode, payload) of the first whole frame in the buffer, which it leaves; None if incomplete."""
        buf = self._buffer
        if len(buf) < 2:
            return None
        n, at = buf[1] & 0x7F, 2
        if n == 126:
            if len(buf) < 4:
                return None
            n, at = struct.unpack("!H", buf[2:4])[0], 4
        elif n == 127:
            if len(buf) < 10:
                return None
            n, at = struct.unpack("!Q", buf[2:10])[0], 10
        if len(buf) < at + n:
            return None
        self._buffer = buf[at + n :]
        return buf[0] & 0x0F, buf[at : at + n]

    def receive(self, timeout: float | None = None) -> Any:
        """The next JSON message (pings are answered, other frames skipped); None when nothing arrives
        within `timeout` s; NuttyError once the server closed the connection."""
        self.sock.settimeout(timeout)
        try:
            while True:
                frame = self._frame()
                if frame is None:
                    chunk = self.sock.recv(65536)
                    if not chunk:
                        raise ConnectionError("the server closed the connection")
                    self._buffer += chunk
                    continue
                opcode, payload = frame
                if opcode == 0x8:  # close: a 2-byte code, then why
                    code = struct.unpack("!H", payload[:2])[0] if len(payload) >= 2 else 1005
                    self.closed, self.close_reason = True, payload[2:].decode("utf-8", "replace") or "closed"
                    if code == 4401:
                        raise NuttyError(
                            f"the server at {self.where} needs its token: set it in the Nutty panel"
                        )
                    raise NuttyError(f"{self.where} closed the connection: {self.close_reason}")
                if opcode == 0x9:
                    self._send_frame(0xA, payload)
                elif opcode == 0x1:
                    return json.loads(payload.decode("utf-8"))
        except TimeoutError:
            return None
        except (OSError, ValueError) as exc:
            self.closed, self.close_reason = True, str(exc)
            raise NuttyError(f"the connection to {self.where} dropped: {exc}") from None

    def close(self) -> None:
        if not self.closed:
            with contextlib.suppress(OSError):
                self._send_frame(0x8, struct.pack("!H", 1000))
        self.closed = True
        with contextlib.suppress(OSError):
            self.sock.close()

"""The server's boundary: who may change the robot, and what a request may contain.

One place for every rule the API enforces before a route runs (`Guard`, pure ASGI middleware) and
for the JSON-safety checks every entry point shares (`loads`, `check_json`, `dumps`, in
backend.safe_json):

- Authority. Every HTTP request (reads too: the robot's state is nobody else's business) and every
  WebSocket handshake must come from an allowed `Origin` when the header is present (browsers always
  send it cross-origin; curl and Python clients send none and stay allowed), and name an allowed
  `Host` (against DNS rebinding: a hostile page whose name resolves to 127.0.0.1 still sends its own
  name as Host). With a token, a mutating request (POST/PUT/PATCH/DELETE), every WebSocket and the
  Pre-Viz also need `Authorization: Bearer <token>` (or `?token=<token>`, the only form a browser
  WebSocket can send). A refused HTTP request gets 403/401 JSON, a refused WebSocket
  is accepted and closed at once with code 4403/4401 and a reason, so clients can tell why.
- Limits. Request bodies are counted as they stream in and stopped at `MAX_BODY` with 413 (a
  chunked body has no Content-Length to check up front). JSON is parsed with NaN/Infinity, numbers
  that overflow to infinity, integers beyond 2**63, invalid Unicode (lone surrogates), a key given
  twice and nesting deeper than `MAX_DEPTH` refused with a 4xx that names the field.
- Output. `dumps` never fails: a value that cannot be serialised (NaN, a lone surrogate echoed in
  an error message) is sanitised rather than turned into a 500 or a dead socket.
"""

from __future__ import annotations

import asyncio
import hashlib
import hmac
import ipaddress
import secrets
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qs, urlsplit

# The JSON rules every entry point shares live in backend.safe_json; importable from here as well.
from backend.safe_json import (  # noqa: F401 (re-exported: the names were importable from here before the split)
    MAX_BODY,
    MAX_DEPTH,
    MAX_INT,
    MAX_MESSAGE,
    JsonSafetyError,
    check_json,
    dumps,
    error_body,
    loads,
    safe_text,
    sanitize,
)

MAX_WS_MESSAGE = MAX_MESSAGE  # bytes per WebSocket message: one limit for every command message
MUTATING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
WILDCARD_HOSTS = frozenset({"0.0.0.0", "::", ""})
PREVIZ_PREFIX = "/previz"
PREVIZ_COOKIE = "nutty_previz"
JSON_TYPES = ("application/json",)
SIMPLE_TYPES = ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data")


# --------------------------------------------------------------------------------------------------
# Origins, hosts and the token
# --------------------------------------------------------------------------------------------------


def _norm_host(name: str) -> str:
    name = name.strip().lower().rstrip(".")
    if name.startswith("[") and name.endswith("]"):
        name = name[1:-1]
    return name


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
        return True
    except ValueError:
        return False


def split_host(value: str, default_port: int | None = 80) -> tuple[str, int | None] | None:
    """`host[:port]` (IPv6 in brackets) -> (host, port); None when malformed."""
    value = value.strip()
    if not value:
        return None
    if value.startswith("["):
        end = value.find("]")
        if end < 0:
            return None
        host, rest = value[1:end], value[end + 1 :]
        if rest and not rest.startswith(":"):
            return None
        port_s = rest[1:] if rest else ""
    elif value.count(":") == 1:
        host, port_s = value.split(":")
    elif ":" in value:
        return None  # a bare IPv6 address is not a valid Host header
    else:
        host, port_s = value, ""
    if port_s:
        if not port_s.isdigit() or not 0 < int(port_s) < 65536:
            return None
        port: int | None = int(port_s)
    else:
        port = default_port
    host = _norm_host(host)
    return (host, port) if host else None


def parse_origin(origin: str) -> tuple[str, str, int] | None:
    """`scheme://host[:port]` -> (scheme, host, port); None for `null` and anything else."""
    try:
        parts = urlsplit(origin.strip())
        port = parts.port
    except ValueError:
        return None
    if (
        parts.scheme not in ("http", "https")
        or not parts.hostname
        or parts.path not in ("", "/")
        or parts.query
        or parts.fragment
        or parts.username
        or parts.password
    ):
        return None
    return parts.scheme, _norm_host(parts.hostname), port or (443 if parts.scheme == "https" else 80)


def default_origins(host: str, port: int) -> list[str]:
    """The server's own origins: loopback names on its port, plus its bound address if specific."""
    out = [f"http://localhost:{port}", f"http://127.0.0.1:{port}", f"http://[::1]:{port}"]
    h = _norm_host(host)
    if h not in WILDCARD_HOSTS and h not in LOOPBACK_NAMES:
        out.append(f"http://[{h}]:{port}" if ":" in h else f"http://{h}:{port}")
    return out


def previz_cookie_value(token: str) -> str:
    """What the Pre-Viz cookie holds: a MAC of the token, never the token itself."""
    return hmac.new(token.encode("utf-8", "surrogatepass"), b"nutty-previz", hashlib.sha256).hexdigest()


@dataclass
class AccessPolicy:
    """Which Origins and Hosts may change the robot, and the token.

    `port` None (an app not bound to a socket: tests, embedding) accepts any port, and Starlette's
    TestClient host name `testserver`. `allowed_origins` are extra origins (`--allowed-origin`); the
    server's own origins are always allowed, and so is a same-origin request (Origin equal to the
    Host the request named, once that Host passed its own check).
    """

    token: str | None = None
    port: int | None = None
    bind_host: str = "127.0.0.1"
    allowed_origins: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._origins: set[tuple[str, str, int]] = set()
        self._extra_names: set[str] = set()
        own = default_origins(self.bind_host, self.port) if self.port is not None else []
        for o in [*own, *self.allowed_origins]:
            parsed = parse_origin(o)
            if parsed is None:
                raise ValueError(f"invalid origin {o!r}: expected scheme://host[:port]")
            self._origins.add(parsed)
            if o in self.allowed_origins:  # named by the operator, beyond this server's own
                self._extra_names.add(parsed[1])
        bound = _norm_host(self.bind_host)
        self._wildcard = bound in WILDCARD_HOSTS
        self._names: set[str] = set(LOOPBACK_NAMES)
        if not self._wildcard:
            self._names.add(bound)
        if self.port is None:
            self._names.add("testserver")
        # Names from allowed origins: on this server's port, or on the origin's own (a reverse proxy).
        self._names |= {h for _, h, _ in self._origins}
        self._origin_hosts: set[tuple[str, int]] = {(h, p) for _, h, p in self._origins}

    @property
    def origins(self) -> list[str]:
        return sorted(f"{s}://[{h}]:{p}" if ":" in h else f"{s}://{h}:{p}" for s, h, p in self._origins)

    def host_problem(self, host_header: str | None, scheme: str = "http") -> str | None:
        if not host_header:
            return "the request names no Host"
        parsed = split_host(host_header, None)
        if parsed is None:
            return "malformed Host header"
        name, explicit = parsed
        if explicit is None and name in self._extra_names:
            return None  # an --allowed-origin's name behind a reverse proxy (Host without a port)
        port = explicit if explicit is not None else (443 if scheme in ("https", "wss") else 80)
        if (name, port) in self._origin_hosts:
            return None
        known = name in self._names or (self._wildcard and _is_ip(name))
        if not known:
            return (
                f"Host '{safe_text(name)}' is not this server (DNS rebinding?); add it with --allowed-origin"
            )
        if self.port is not None and port != self.port:
            return f"Host port {port} is not this server's port {self.port}"
        return None

    def origin_problem(self, origin: str | None, host_header: str | None, scheme: str = "http") -> str | None:
        if origin is None:
            return None  # not a browser (curl, Python): nothing to forge
        parsed = parse_origin(origin)
        if parsed is None:
            return f"Origin '{safe_text(origin)[:100]}' is not allowed"
        if parsed in self._origins:
            return None
        host = split_host(host_header or "", 443 if scheme in ("https", "wss") else 80)
        if (
            host is not None
            and (parsed[1], parsed[2]) == host
            and self.host_problem(host_header, scheme) is None
        ):
            return None  # same origin as the Host this request was sent to
        return f"Origin '{safe_text(origin)[:100]}' is not allowed (see --allowed-origin)"

    def token_ok(self, headers: dict[str, str], query_string: str, previz: bool = False) -> bool:
        if self.token is None:
            return True
        want = self.token.encode("utf-8", "surrogatepass")
        auth = headers.get("authorization", "")
        if auth[:7].lower() == "bearer " and secrets.compare_digest(
            auth[7:].strip().encode("utf-8", "surrogatepass"), want
        ):
            return True
        for value in parse_qs(query_string, keep_blank_values=True).get("token", []):
            if secrets.compare_digest(value.encode("utf-8", "surrogatepass"), want):
                return True
        if previz:
            cookie = _cookies(headers.get("cookie", "")).get(PREVIZ_COOKIE)
            if cookie is not None and secrets.compare_digest(
                cookie.encode("utf-8", "surrogatepass"), previz_cookie_value(self.token).encode()
            ):
                return True
        return False


def _cookies(header: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for part in header.split(";"):
        name, sep, value = part.strip().partition("=")
        if sep:
            out.setdefault(name.strip(), value.strip())
    return out


# --------------------------------------------------------------------------------------------------
# The ASGI guard
# --------------------------------------------------------------------------------------------------


class BodyTooLarge(Exception):
    """Raised from the guarded `receive` once a request body passes the limit."""


def _headers(scope: dict[str, Any]) -> dict[str, str]:
    out: dict[str, str] = {}
    for k, v in scope.get("headers") or []:
        name = k.decode("latin-1").lower()
        value = v.decode("latin-1")
        out[name] = f"{out[name]}, {value}" if name in out and name != "cookie" else value
    return out


def content_type_problem(content_type: str | None) -> str | None:
    """None when the body is declared JSON; else why not (simple-request types are refused)."""
    if content_type is None:
        return "send the body with 'Content-Type: application/json'"
    media = content_type.split(";", 1)[0].strip().lower()
    if media in JSON_TYPES or (media.startswith("application/") and media.endswith("+json")):
        return None
    return f"Content-Type '{safe_text(media)[:80]}' is not accepted: send 'application/json'"


class Guard:
    """Pure ASGI middleware enforcing the AccessPolicy and the body limit (see the module doc)."""

    def __init__(
        self,
        app: Any,
        policy: AccessPolicy,
        max_body: int = MAX_BODY,
        token_prefixes: Iterable[str] = (PREVIZ_PREFIX,),
        body_limits: Iterable[tuple[str, int]] = (),
    ):
        self.app = app
        self.policy = policy
        self.max_body = max_body
        self.token_prefixes = tuple(token_prefixes)
        # (path prefix, bytes): routes that take more than a JSON document (a sound file)
        self.body_limits = tuple(body_limits)

    def _body_limit(self, path: str) -> int:
        return next((n for p, n in self.body_limits if path.startswith(p + "/")), self.max_body)

    def _protected(self, path: str) -> bool:
        return any(path == p or path.startswith(p + "/") for p in self.token_prefixes)

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        kind = scope["type"]
        if kind == "http":
            await self._http(scope, receive, send)
        elif kind == "websocket":
            await self._websocket(scope, receive, send)
        else:
            await self.app(scope, receive, send)

    def _problem(self, scope: dict[str, Any], headers: dict[str, str]) -> tuple[int, str, str] | None:
        scheme = scope.get("scheme", "http")
        msg = self.policy.host_problem(headers.get("host"), scheme)
        if msg is not None:
            return 403, "forbidden_host", msg
        msg = self.policy.origin_problem(headers.get("origin"), headers.get("host"), scheme)
        if msg is not None:
            return 403, "forbidden_origin", msg
        return None

    async def _http(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        headers = _headers(scope)
        method = scope.get("method", "GET")
        path = scope.get("path", "")
        qs = scope.get("query_string", b"").decode("latin-1")
        # Reads too: a DNS-rebinding page (a foreign Host) or another site's script (a foreign Origin)
        # must not read the robot's state any more than change it.
        problem = self._problem(scope, headers)
        if problem is not None:
            return await _send_json(send, problem[0], error_body(problem[1], problem[2]))
        protected = self._protected(path)
        if (method in MUTATING or protected) and not self.policy.token_ok(headers, qs, previz=protected):
            return await _send_json(
                send,
                401,
                error_body(
                    "unauthorized",
                    "this server needs 'Authorization: Bearer <token>' (or ?token=<token>)",
                ),
                [(b"www-authenticate", b"Bearer")],
            )
        length = headers.get("content-length")
        limit = self._body_limit(path)
        if length is not None:
            if not length.strip().isdigit():
                return await _send_json(send, 400, error_body("bad_request", "malformed Content-Length"))
            if int(length) > limit:
                return await _send_json(
                    send, 413, error_body("too_large", f"request body over {limit} bytes")
                )
        seen = 0
        started = False

        async def counted_receive() -> dict[str, Any]:
            nonlocal seen
            message = await receive()
            if message.get("type") == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    raise BodyTooLarge()
            return message

        async def tracked_send(message: dict[str, Any]) -> None:
            nonlocal started
            if message.get("type") == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, counted_receive, tracked_send)
        except BodyTooLarge:
            if not started:
                await _send_json(send, 413, error_body("too_large", f"request body over {limit} bytes"))

    async def _websocket(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        headers = _headers(scope)
        path = scope.get("path", "")
        problem = self._problem(scope, headers)
        code, reason = None, ""
        if problem is not None:
            code, reason = 4403, f"{problem[1]}: {problem[2]}"
        elif not self.policy.token_ok(
            headers, scope.get("query_string", b"").decode("latin-1"), previz=self._protected(path)
        ):
            code, reason = 4401, "unauthorized: add ?token=<token>"
        if code is None:
            return await self.app(scope, receive, send)
        message = await receive()
        if message.get("type") != "websocket.connect":
            return
        # Accept (with the client's first subprotocol, or browsers fail the handshake without a code)
        # and close at once, so the client sees the code and the reason.
        offered = scope.get("subprotocols") or []
        await send({"type": "websocket.accept", "subprotocol": offered[0] if offered else None})
        reason_bytes = safe_text(reason).encode("utf-8")[:120].decode("utf-8", "ignore")
        await send({"type": "websocket.close", "code": code, "reason": reason_bytes})


async def cancel_all(tasks: list[Any]) -> None:
    """Cancel `tasks` and wait until they have finished; their exceptions are retrieved, never raised.

    (`asyncio.wait`, not `gather`: a gather cancelled from outside re-raises a child's
    CancelledError, which an enclosing anyio cancel scope does not recognise as its own.)
    """

    for t in tasks:
        t.cancel()
    pending = [t for t in tasks if not t.done()]
    if pending:
        await asyncio.wait(pending)
    for t in tasks:
        if t.done() and not t.cancelled():
            t.exception()


async def _send_json(
    send: Any, status: int, body: dict[str, Any], extra_headers: list[tuple[bytes, bytes]] | None = None
) -> None:
    data = dumps(body).encode("utf-8")
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(data)).encode()),
                *(extra_headers or []),
            ],
        }
    )
    await send({"type": "http.response.body", "body": data})
